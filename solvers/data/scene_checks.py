"""Validation of a scene's fields, one check per key, and the checks that involve several fields."""

from __future__ import annotations

import sys

from typing import TYPE_CHECKING, Any, Mapping

from pulsemap.symbolic.frozenmap import FrozenMap
from pulsemap.solvers.data.scene_params import _check_perturbation_object, _scene_hint
from pulsemap.solvers.data.scene_schema import (
    _SCHEMA,
    DNS_DEFAULTS,
    DNS_ENGINES,
    DNS_MODES,
    DNS_METHODS,
    MAX_BEADS,
    METHODS,
    PROFILES,
    VARIANTS,
    SceneError,
    _as_table,
    _integer,
    _number,
    _Problem,
    _suggest,
    _type_name,
    _unknown,
)

if TYPE_CHECKING:  # pragma: no cover
    from pulsemap.solvers.data.scene_spec import Scene


def _check_fields(raw: Mapping[str, Any]) -> dict[str, Any]:
    """Validate and normalise the plain (non-perturbation) fields present in ``raw``."""
    checks = {
        "name": _check_name,
        "beads": _check_beads,
        "exponent": _check_exponent,
        "first_perturbed": _check_first_perturbed,
        "velocity": _check_velocity,
        "contacts": _check_contacts,
        "methods": _check_methods,
        "profile": lambda v: _check_choice(v, "[model] profile", PROFILES),
        "variant": lambda v: _check_choice(v, "[model] variant", VARIANTS),
        "dns": lambda v: v if isinstance(v, FrozenMap) else _check_dns_table(_as_table(v, "dns")),
        "source": _check_source,
        "perturbation": _check_perturbation_object,
    }
    return {key: checks[key](value) for key, value in raw.items()}


def _check_name(value: Any) -> str:
    if not isinstance(value, str) or not value.strip():
        raise _Problem(f"name must be a non-empty string, got {_type_name(value)}: e.g. name = \"damping-eps0.3\"")
    if any(not c.isprintable() for c in value):
        raise _Problem(f"name {value!r} contains control characters: use a short one-line name")
    return value.strip()


def _check_source(value: Any) -> str:
    if not isinstance(value, str):
        raise _Problem(f"source must be a string (a path or builtin:NAME), got {_type_name(value)}")
    return value


def _check_beads(value: Any) -> int | None:
    if value is None:
        return None
    beads = _integer(value, "[chain] beads")
    if beads < 3:
        raise _Problem(f"[chain] beads = {beads} is too short: give an integer >= 3, or omit it to size the chain from the contacts")
    if beads > MAX_BEADS:
        raise _Problem(f"[chain] beads = {beads} is larger than the supported {MAX_BEADS}: use a shorter chain")
    return beads


def _check_exponent(value: Any) -> float:
    from pulsemap.symbolic.profile import ProfileError, check_exponent

    n = _number(value, "[chain] exponent")
    try:
        return check_exponent(n)
    except ProfileError as exc:
        raise _Problem(f"[chain] exponent: {exc}") from None


def _check_first_perturbed(value: Any) -> int:
    first = _integer(value, "[chain] first_perturbed")
    if first < 2:
        raise _Problem(
            f"[chain] first_perturbed = {first} must be >= 2: the map is seeded by the unperturbed contact "
            "first_perturbed - 1 (the paper uses 16)"
        )
    return first


def _check_velocity(value: Any) -> float:
    v0 = _number(value, "[excitation] velocity")
    if v0 <= 0:
        raise _Problem(f"[excitation] velocity = {v0} must be > 0: bead 1 is pushed into the chain (e.g. velocity = 1.0)")
    from pulsemap.solvers.chain.scaling import ScalingError, check_velocity_range

    try:
        check_velocity_range(v0, "[excitation] velocity")
    except ScalingError as exc:
        raise _Problem(str(exc)) from None
    return v0


def _check_contacts(value: Any) -> tuple[int, int]:
    if isinstance(value, (str, Mapping)) or not isinstance(value, (list, tuple)) or len(value) != 2:
        shown = f"{_type_name(value)}" if not isinstance(value, (list, tuple)) else f"an array of {len(value)}"
        raise _Problem(f"[output] contacts must be [first, last], got {shown}: e.g. contacts = [16, 120]")
    first = _integer(value[0], "[output] contacts first")
    last = _integer(value[1], "[output] contacts last")
    if first < 1:
        raise _Problem(f"[output] contacts = [{first}, {last}]: contacts are 1-based, the first must be >= 1")
    if first > last:
        raise _Problem(f"[output] contacts = [{first}, {last}] is reversed: write [{last}, {first}] (first <= last)")
    if last > MAX_BEADS:
        raise _Problem(f"[output] contacts last = {last} is beyond the supported {MAX_BEADS} beads: lower it")
    return first, last


def _check_methods(value: Any) -> tuple[str, ...]:
    if isinstance(value, str):
        value = [value]
    if not isinstance(value, (list, tuple)):
        raise _Problem(f"[output] methods must be an array of names, got {_type_name(value)}: e.g. methods = [\"map\", \"dns\"]")
    if not value:
        raise _Problem(f"[output] methods is empty: list at least one of {', '.join(METHODS)}")
    for item in value:
        if not isinstance(item, str):
            raise _Problem(f"[output] methods must hold strings, got {_type_name(item)}: choose from {', '.join(METHODS)}")
        if item not in METHODS:
            raise _Problem(f"unknown method {item!r} in [output] methods{_suggest(item, METHODS)}: choose from {', '.join(METHODS)}")
    return tuple(m for m in METHODS if m in value)


def check_choice(value: Any, what: str, choices: tuple[str, ...] | list[str]) -> str:
    """``value`` if it is one of ``choices``, else a one-line SceneError naming them (and the closest)."""
    try:
        return _check_choice(value, what, tuple(choices))
    except _Problem as exc:
        raise SceneError(str(exc)) from None


def _check_choice(value: Any, key: str, choices: tuple[str, ...]) -> str:
    if not isinstance(value, str):
        raise _Problem(f"{key} must be a string, got {_type_name(value)}: choose one of {', '.join(choices)}")
    if value not in choices:
        raise _Problem(f"unknown {key} {value!r}{_suggest(value, choices)}: choose one of {', '.join(choices)}")
    return value


MIN_RTOL = 100 * sys.float_info.epsilon
"""Smallest rtol float64 can deliver (= solvers.chain.dns.MIN_RTOL; scipy raises a smaller one silently)."""


def _check_dns_table(table: Mapping[str, Any]) -> FrozenMap:
    for key in table:
        if key not in _SCHEMA["dns"]:
            raise _Problem(_unknown(key, _SCHEMA["dns"], "in [dns]"))
    values: dict[str, Any] = {}
    for key in ("rtol", "atol"):
        tol = _number(table[key], f"[dns] {key}")
        if tol <= 0 or (key == "rtol" and tol >= 1):
            bound = "0 < rtol < 1" if key == "rtol" else "atol > 0"
            raise _Problem(f"[dns] {key} = {tol} is out of range: give {bound} (default {DNS_DEFAULTS[key]})")
        if key == "rtol" and tol < MIN_RTOL:
            raise _Problem(f"[dns] rtol = {tol:g} is below what float64 can deliver: give rtol >= {MIN_RTOL:.2g} "
                           "(100 x machine epsilon)")
        values[key] = tol
    values["method"] = _check_choice(table["method"], "[dns] method", DNS_METHODS)
    if "engine" in table:
        values["engine"] = _check_choice(table["engine"], "[dns] engine", DNS_ENGINES)
    if "mode" in table:
        values["mode"] = _check_choice(table["mode"], "[dns] mode", DNS_MODES)
    return FrozenMap(tuple(values.items()))


def _check_consistency(scene: Scene) -> None:
    """Checks that involve several fields: chain length, contacts, first_perturbed, per-bead values."""
    from pulsemap.symbolic.perturbation import PerturbationError, RandomDraw

    first, last = scene.contacts
    if scene.beads is not None:
        if last > scene.beads - 1:
            raise _Problem(
                f"contact {last} is beyond a chain of {scene.beads} beads (last contact {scene.beads - 1}): "
                "raise beads or lower contacts"
            )
        if scene.first_perturbed > scene.beads:
            raise _Problem(
                f"[chain] first_perturbed = {scene.first_perturbed} is beyond a chain of {scene.beads} beads: "
                "lower first_perturbed or raise beads"
            )
    seeded = [m for m in METHODS if m != "dns" and m in scene.methods]
    if seeded and first < scene.first_perturbed:
        raise _Problem(
            f"[output] contacts start at {first}, before first_perturbed = {scene.first_perturbed}, but "
            f"{' and '.join(seeded)} start at the first perturbed contact (seeded by contact "
            f"{scene.first_perturbed - 1}): set contacts = [{scene.first_perturbed}, {last}] or methods = [\"dns\"]"
        )
    pert = scene.perturbation
    if scene.beads is None:
        for pname, value in pert.params.items():
            if isinstance(value, (tuple, RandomDraw)):
                kind = f"a list of {len(value)} per-bead values" if isinstance(value, tuple) else "a random draw"
                raise _Problem(
                    f"parameter '{pname}' is {kind}, so the chain length must be known: set [chain] beads "
                    f"(more than the last contact {last})"
                )
        return
    try:
        for pname, value in pert.params.items():
            if not isinstance(value, float):  # a scalar has a value on every bead
                pert.bead_values(pname, scene.beads)
        pert.check_at_rest(1 if pert.is_uniform else scene.beads)  # uniform R: every bead alike, O(1)
    except PerturbationError as exc:
        raise _Problem("[perturbation] " + _scene_hint(str(exc))) from None
