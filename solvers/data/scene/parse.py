"""A scene's table -> a validated :class:`Scene`: the one place scene input is checked.

The table's structure (decoded from TOML by :mod:`.files`, or built in Python) is checked against
:mod:`.schema`, then each field (one check per key), the [perturbation] table (R, eps and the
parameter forms; make_perturbation's errors as scene problems) and the checks that involve several
fields. Every problem is a one-line :class:`SceneError` naming the scene, the problem and the fix.
``pulsemap.symbolic.perturbation`` pulls in sympy, so it is imported inside the functions.
"""

from __future__ import annotations

import math
import numbers
import os
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

from pulsemap.symbolic.errors import closest
from pulsemap.symbolic.frozenmap import FrozenMap
from pulsemap.symbolic.param_forms import param_data
from pulsemap.solvers.chain.methods import MIN_ATOL, MIN_RTOL
from pulsemap.solvers.data.scene.schema import (
    DEFAULT_EXPONENT,
    DEFAULT_FIRST_PERTURBED,
    DEFAULT_METHODS,
    DNS_DEFAULTS,
    DNS_ENGINES,
    DNS_METHODS,
    DNS_MODES,
    EXAMPLES,
    FIELD_KEYS,
    MAX_BEADS,
    METHODS,
    PERTURBATION_TABLES,
    PROFILES,
    REQUIRED_KEYS,
    REQUIRED_TABLES,
    SCHEMA,
    TABLES,
    VARIANTS,
    SceneError,
)
from pulsemap.solvers.data.scene.spec import Scene

if TYPE_CHECKING:  # pragma: no cover
    from pulsemap.symbolic.perturbation import Perturbation


def override_changes(scene: Scene, kw: Mapping[str, Any]) -> list[tuple[str, Any]]:
    """overrides.with_overrides keywords -> (dotted key, value) changes for apply_overrides."""
    allowed = sorted(FIELD_KEYS.keys() | {"dns", "perturbation"})
    changes: list[tuple[str, Any]] = []
    try:
        for key, value in kw.items():
            if key not in allowed:
                raise _Problem(_unknown(key, allowed, "in with_overrides()"))
            if key == "dns":
                changes += [(f"dns.{k}", v) for k, v in _as_table(value, "dns").items()]
            elif key == "perturbation":
                if {"R", "eps", "params"} & kw.keys():
                    raise _Problem("give either perturbation or R/eps/params, not both")
                pert = _check_perturbation_object(value)
                changes += [("perturbation.R", pert.text), ("perturbation.eps", pert.eps),
                            ("perturbation.params", {k: param_data(v) for k, v in pert.params.items()})]
            else:
                changes.append((FIELD_KEYS[key], value))
    except _Problem as exc:
        raise SceneError(_prefix(scene.source, scene.name) + str(exc)) from None
    return changes


MAX_NAME = 1000  # characters of a scene's name: a label in reports (--set adds each change to it, shortened)


class _Problem(Exception):
    """A problem found by a field check; turned into a SceneError with the scene's name."""


def _prefix(source: str, name: str) -> str:
    if not source or source in (f"builtin:{name}", f"suite:{name}"):
        return f"scene '{name}': "
    return f"{source} (scene '{name}'): "


def _as_table(value: Any, table: str) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise _Problem(f"'{table}' must be a table [{table}], got {_type_name(value)}: write [{table}] on its own line")
    return value


def _unknown(key: str, known: tuple[str, ...] | list[str], where: str) -> str:
    return f"unknown key {key!r} {where}{suggest(key, known)}; known keys: {', '.join(known)}"


def suggest(word: object, known: tuple[str, ...] | list[str], left: str = "'", right: str = "'") -> str:
    close = closest(str(word), known)
    return f" (did you mean {left}{close}{right}?)" if close else ""


def _type_name(value: object) -> str:
    if isinstance(value, bool):
        return f"a boolean ({str(value).lower()})"
    if isinstance(value, numbers.Integral):
        return f"an integer ({value})"
    if isinstance(value, numbers.Real):
        return f"a float ({value})"
    if isinstance(value, str):
        shown = value if len(value) <= 40 else value[:37] + "..."
        return f"a string ({shown!r})"
    if isinstance(value, Mapping):
        return "a table"
    if isinstance(value, (list, tuple)):
        return "an array"
    if value is None:
        return "nothing"
    return f"a {type(value).__name__}"


def _integer(value: Any, key: str) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        fix = " (remove the quotes)" if isinstance(value, str) else ""
        raise _Problem(f"{key} must be an integer, got {_type_name(value)}{fix}")
    return int(value)


def _number(value: Any, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        fix = " (remove the quotes)" if isinstance(value, str) else ""
        raise _Problem(f"{key} must be a number, got {_type_name(value)}{fix}")
    try:
        result = float(value)
    except OverflowError:  # a TOML integer of hundreds of digits
        raise _Problem(f"{key} = {str(value)[:12]}... ({len(str(value))} digits) is beyond float64 "
                       "(about 1.8e308): give a finite number") from None
    if not math.isfinite(result):
        raise _Problem(f"{key} = {result} is not finite: give a finite number")
    return result


def parse_scene(data: Mapping[str, Any], source: str) -> Scene:
    """Validate an already-parsed TOML table (or :meth:`Scene.as_dict`) and return the Scene."""
    if not isinstance(source, (str, os.PathLike)):
        raise TypeError(f"source must be a string naming where the scene came from (a path or builtin:NAME), "
                        f"got {type(source).__name__}")
    source = str(source)
    name = _default_name(source)
    try:
        if not isinstance(data, Mapping):
            raise _Problem(f"a scene must be a table of tables, got {_type_name(data)}")
        if "name" in data:
            name = _check_name(data["name"])
        _check_structure(data)
        tables = {key: _as_table(data.get(key, {}), key) for key in TABLES}
        chain, output = tables["chain"], tables["output"]
        raw = {
            "name": name,
            "beads": chain.get("beads"),
            "exponent": chain.get("exponent", DEFAULT_EXPONENT),
            "first_perturbed": chain.get("first_perturbed", DEFAULT_FIRST_PERTURBED),
            "velocity": tables["excitation"]["velocity"],
            "contacts": output["contacts"],
            "methods": output.get("methods", list(DEFAULT_METHODS)),
            "profile": tables["model"].get("profile", "exact"),
            "variant": tables["model"].get("variant", "paper"),
            "dns": _check_dns_table({**DNS_DEFAULTS, **tables["dns"]}),
            "source": source,
        }
        fields = _check_fields(raw)
        fields["perturbation"] = _build_perturbation(data.get("perturbation", {"R": "0", "eps": 0.0}), name)
        fields["contact"] = _build_contact(tables["contact"]) if "contact" in data else None
        fields["masses"] = _build_masses(tables["masses"]) if "masses" in data else None
        scene = Scene(**fields)
        _check_consistency(scene)
    except _Problem as exc:
        raise SceneError(_prefix(source, name) + str(exc)) from None
    return scene


def _default_name(source: str) -> str:
    if source.startswith("builtin:"):
        return source[len("builtin:"):]
    stem = Path(source).name
    return stem[: -len(".toml")] if stem.endswith(".toml") else (stem or "scene")


def _check_structure(data: Mapping[str, Any]) -> None:
    """Unknown tables and keys (with suggestions), tables given as values, missing keys."""
    for key, value in data.items():
        if key not in SCHEMA[""]:
            if isinstance(value, Mapping):
                raise _Problem(
                    f"unknown table [{key}]{suggest(key, TABLES, '[', ']')}: "
                    f"known tables are {', '.join(f'[{t}]' for t in TABLES)}"
                )
            raise _Problem(_unknown(key, SCHEMA[""], "at the top level"))
    for table in TABLES:
        if table not in data:
            if table == "perturbation" and any(t in data for t in PERTURBATION_TABLES):
                continue  # a contact-law or mass perturbation alone: R = 0
            if table in REQUIRED_TABLES:
                key = REQUIRED_KEYS[table][0]
                raise _Problem(
                    f"missing table [{table}]: add it with at least "
                    f"{EXAMPLES.get(f'{table}.{key}', key + ' = ...')}"
                )
            continue
        content = _as_table(data[table], table)
        for key, value in content.items():
            if key not in SCHEMA[table]:
                if isinstance(value, Mapping):
                    raise _Problem(
                        f"unknown table [{table}.{key}]{suggest(key, SCHEMA[table], f'[{table}.', ']')}: "
                        f"[{table}] holds {', '.join(SCHEMA[table])}"
                    )
                if key in SCHEMA[""]:
                    raise _Problem(
                        f"key {key!r} is inside [{table}] but belongs at the top level: move it above "
                        f"the first table header{' or write [' + key + '] on its own line' if key in TABLES else ''}"
                    )
                raise _Problem(_unknown(key, SCHEMA[table], f"in [{table}]"))
        for key in REQUIRED_KEYS.get(table, ()):
            if key not in content:
                raise _Problem(
                    f"missing key {key!r} in [{table}]: add {EXAMPLES.get(f'{table}.{key}', key + ' = ...')}"
                )
    for table in PERTURBATION_TABLES:
        params = _as_table(data.get(table, {}), table).get("params", {})
        if not isinstance(params, Mapping):
            raise _Problem(f"[{table}] params must be a table [{table}.params] of NAME = VALUE, got {_type_name(params)}")


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
    if len(value) > MAX_NAME:
        raise _Problem(f"name is {len(value)} characters long, more than {MAX_NAME}: use a short one-line name")
    if any(not c.isprintable() for c in value):
        raise _Problem(f"name {value[:40]!r} contains control characters: use a short one-line name")
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
            raise _Problem(f"unknown method {item!r} in [output] methods{suggest(item, METHODS)}: choose from {', '.join(METHODS)}")
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
        raise _Problem(f"unknown {key} {value!r}{suggest(value, choices)}: choose one of {', '.join(choices)}")
    return value


def _check_dns_table(table: Mapping[str, Any]) -> FrozenMap:
    for key in table:
        if key not in SCHEMA["dns"]:
            raise _Problem(_unknown(key, SCHEMA["dns"], "in [dns]"))
    values: dict[str, Any] = {}
    for key in ("rtol", "atol"):
        tol = _number(table[key], f"[dns] {key}")
        if tol <= 0 or (key == "rtol" and tol >= 1):
            bound = "0 < rtol < 1" if key == "rtol" else "atol > 0"
            raise _Problem(f"[dns] {key} = {tol} is out of range: give {bound} (default {DNS_DEFAULTS[key]})")
        if key == "rtol" and tol < MIN_RTOL:
            raise _Problem(f"[dns] rtol = {tol:g} is below what float64 can deliver: give rtol >= {MIN_RTOL:.2g} "
                           "(100 x machine epsilon)")
        if key == "atol" and tol < MIN_ATOL:
            raise _Problem(f"[dns] atol = {tol:g} is below what the error norm can use: give atol >= {MIN_ATOL:g} "
                           "(the norm squares error/atol, which leaves float64 below ~1e-154)")
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
    _check_chain_fits(scene.beads, scene.first_perturbed, scene.contacts, scene.methods)
    _check_chain_terms(scene)
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


def _check_chain_fits(beads: int | None, first_perturbed: int, contacts: tuple[int, int],
                      methods: tuple[str, ...]) -> None:
    """The chain holds the contacts and first_perturbed; the seeded models start where R does."""
    first, last = contacts
    if beads is not None:
        if last > beads - 1:
            raise _Problem(
                f"contact {last} is beyond a chain of {beads} beads (last contact {beads - 1}): "
                "raise beads or lower contacts"
            )
        if first_perturbed > beads:
            raise _Problem(
                f"[chain] first_perturbed = {first_perturbed} is beyond a chain of {beads} beads: "
                "lower first_perturbed or raise beads"
            )
    seeded = [m for m in METHODS if m != "dns" and m in methods]
    if seeded and first < first_perturbed:
        raise _Problem(
            f"[output] contacts start at {first}, before first_perturbed = {first_perturbed}, but "
            f"{' and '.join(seeded)} start at the first perturbed contact (seeded by contact "
            f"{first_perturbed - 1}): set contacts = [{first_perturbed}, {last}] or methods = [\"dns\"]"
        )


def check_recorded_scene(d: Mapping[str, Any]) -> dict[str, Any]:
    """A scene record read back (:meth:`Scene.as_dict` from the cache) checked as a scene file is, without
    sympy: every plain field by its own check, the chain against the contacts, eps, the parameter values
    and R's text (printable). Returns the checked plain fields; a SceneError naming the first problem."""
    name, source = "record", ""
    try:
        if not isinstance(d, Mapping):
            raise _Problem(f"a scene record must be a table, got {_type_name(d)}")
        source = d.get("source", "")
        tables = {key: _as_table(d.get(key), key) for key in ("chain", "excitation", "perturbation", "output",
                                                               "model", "dns")}
        chain, output, model = tables["chain"], tables["output"], tables["model"]
        fields = _check_fields({
            "name": d.get("name"), "beads": chain.get("beads"), "exponent": chain.get("exponent"),
            "first_perturbed": chain.get("first_perturbed"), "velocity": tables["excitation"].get("velocity"),
            "contacts": output.get("contacts"), "methods": output.get("methods"), "profile": model.get("profile"),
            "variant": model.get("variant"), "dns": tables["dns"], "source": source})
        name = fields["name"]
        _check_chain_fits(fields["beads"], fields["first_perturbed"], fields["contacts"], fields["methods"])
        pert = tables["perturbation"]
        R = pert.get("R")
        if not isinstance(R, str) or not R.strip() or not R.isprintable():
            raise _Problem(f"[perturbation] R must be a printable formula, got {_type_name(R)}")
        if _number(pert.get("eps"), "[perturbation] eps") < 0:
            raise _Problem(f"[perturbation] eps = {pert.get('eps')} must be >= 0")
        for pname, value in _as_table(pert.get("params"), "perturbation.params").items():
            _check_recorded_param(str(pname), value, fields["beads"])
    except _Problem as exc:
        raise SceneError(_prefix(str(source), str(name)) + str(exc)) from None
    return fields


def _check_recorded_param(name: str, value: Any, beads: int | None) -> None:
    """A recorded parameter value: a finite number, a per-bead list of them (one a bead), or a random draw."""
    key = f"[perturbation.params] {name}"
    if isinstance(value, Mapping):
        bounds, seed = value.get("uniform"), value.get("seed")
        if not (isinstance(bounds, list) and len(bounds) == 2) or isinstance(seed, bool) or not isinstance(seed, int) \
                or seed < 0:
            raise _Problem(f"{key} must be a random draw {{uniform = [lo, hi], seed = s}}, got {_type_name(value)}")
        for bound in bounds:
            _number(bound, key)
    elif isinstance(value, list):
        if beads is None or len(value) != beads:
            raise _Problem(f"{key} holds {len(value)} per-bead values for a chain of {beads} beads")
        for item in value:
            _number(item, key)
    else:
        _number(value, key)


def _check_chain_terms(scene: Scene) -> None:
    """The contact law's per-contact values and the masses against the chain (when its length is known)."""
    from pulsemap.symbolic.param_values import PerturbationError

    if scene.masses is not None:
        try:
            scene.masses.check_list(scene.contacts[1] + 1)
            if scene.beads is not None:
                scene.masses.bead_masses(scene.beads)
        except PerturbationError as exc:
            raise _Problem(str(exc)) from None
    law = scene.contact
    if law is None:
        return
    momentum = [m for m in scene.methods if m.startswith("momentum")]
    if momentum:
        raise _Problem(f"[output] methods has {momentum[0]}, which cannot take a contact-law term: contact forces are "
                       "internal, so the chain's momentum changes only through R; use energy-law or energy-map for P")
    for pname, value in law.params.items():
        if isinstance(value, tuple) and (scene.beads is None or len(value) != scene.beads - 1):
            need = "set [chain] beads to one more than the list's length" if scene.beads is None else \
                f"give exactly {scene.beads - 1} (contacts 1..{scene.beads - 1})"
            raise _Problem(f"[contact] parameter '{pname}' lists {len(value)} per-contact values: {need}")
    if scene.beads is not None:
        try:
            law.table(scene.beads - 1)
        except PerturbationError as exc:
            raise _Problem(f"[contact] {exc}") from None


def _build_perturbation(table: Mapping[str, Any], name: str) -> "Perturbation":
    """make_perturbation(R, eps, params), its errors as one-line problems; every parameter given must
    occur in R (check_all_used)."""
    from pulsemap.symbolic.expression import ExpressionError
    from pulsemap.symbolic.perturbation import PerturbationError, check_all_used, make_perturbation

    R = table["R"]
    if not isinstance(R, str):
        raise _Problem(f"[perturbation] R must be a string formula in u, v, i and parameters, got {_type_name(R)}: e.g. R = \"-mu*v\"")
    eps = _number(table["eps"], "[perturbation] eps")
    params = table.get("params") or {}
    if not isinstance(params, Mapping):
        raise _Problem(f"[perturbation] params must be a table of NAME = VALUE, got {_type_name(params)}")
    try:
        return check_all_used(make_perturbation(R, eps, dict(params)))
    except (PerturbationError, ExpressionError) as exc:
        raise _Problem("[perturbation] " + _scene_hint(str(exc))) from None


def _build_contact(table: Mapping[str, Any]):
    """make_contact_law(P, eps, params, first_perturbed), its errors as one-line problems."""
    from pulsemap.symbolic.contact_law import make_contact_law
    from pulsemap.symbolic.param_values import PerturbationError

    if not isinstance(table["P"], str):
        raise _Problem(f"[contact] P must be a string formula in d, w, k and parameters, got {_type_name(table['P'])}: "
                       "e.g. P = \"gamma*d^(1/2)*w\"")
    eps = _number(table["eps"], "[contact] eps")
    first = _integer(table.get("first_perturbed", DEFAULT_FIRST_PERTURBED), "[contact] first_perturbed")
    try:
        return make_contact_law(table["P"], eps, dict(table.get("params") or {}), first)
    except PerturbationError as exc:
        raise _Problem(_scene_hint(str(exc))) from None


def _build_masses(table: Mapping[str, Any]):
    """make_masses(m, params, first_perturbed), its errors as one-line problems."""
    from pulsemap.symbolic.contact_law import make_masses
    from pulsemap.symbolic.param_values import PerturbationError

    first = _integer(table.get("first_perturbed", DEFAULT_FIRST_PERTURBED), "[masses] first_perturbed")
    try:
        return make_masses(table["m"], dict(table.get("params") or {}), first)
    except PerturbationError as exc:
        raise _Problem(_scene_hint(str(exc))) from None


def _check_perturbation_object(value: Any) -> "Perturbation":
    from pulsemap.symbolic.perturbation import Perturbation

    if not isinstance(value, Perturbation):
        raise _Problem(f"perturbation must be a pulsemap.symbolic.perturbation.Perturbation, got {_type_name(value)}: or pass R, eps, params")
    return value


def _scene_hint(message: str) -> str:
    """Rewrite command-line advice for a scene file; keep the message on one line."""
    message = re.sub(r"--param (\w+)=VALUE", r"\1 = VALUE under [perturbation.params]", message)
    return " ".join(message.split())
