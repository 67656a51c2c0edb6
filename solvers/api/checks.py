"""Argument checks of the public API: TypeError for a wrong type, PulsemapError (a ValueError) for a wrong value,
each naming the argument and, for a choice, the closest allowed value."""

from __future__ import annotations

import math
import numbers
import re
from typing import TYPE_CHECKING, Any, Iterable, Mapping, Sequence

if TYPE_CHECKING:  # pragma: no cover
    from pulsemap.solvers.data.scene import Scene

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.symbolic.errors import closest as closest_name


def closest(word: str, known: Iterable[str]) -> str:
    """' (did you mean 'x'?)' for the closest of ``known``, or ''."""
    match = closest_name(str(word), known)
    return f" (did you mean '{match}'?)" if match else ""


def number(value: Any, name: str) -> float:
    """``value`` as a finite float; TypeError unless it is a real number (not a bool)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a number, got {type(value).__name__} {value!r}")
    out = float(value)
    if not math.isfinite(out):
        raise PulsemapError(f"{name} = {out} is not finite: give a finite number")
    return out


def choice(value: Any, name: str, choices: Iterable[str]) -> str:
    """``value`` if it is one of ``choices``; TypeError for a non-string, ValueError naming the closest."""
    choices = tuple(choices)
    if not isinstance(value, str):
        raise TypeError(f"{name} must be a string, one of {', '.join(choices)}; got {type(value).__name__} {value!r}")
    if value not in choices:
        raise PulsemapError(f"unknown {name} {value!r}{closest(value, choices)}: choose one of {', '.join(choices)}")
    return value


def merged_params(params: Any, keywords: Mapping[str, Any]) -> dict:
    """The parameter values of ``params`` (a mapping or None) and of keyword arguments, each name once."""
    if params is not None and not isinstance(params, Mapping):
        raise TypeError(f"params must be a mapping of parameter names to values, got {type(params).__name__}")
    values = dict(params or {})
    for name, value in keywords.items():
        if name in values:
            raise PulsemapError(f"parameter {name!r} given twice (as a keyword and in params)")
        values[name] = value
    return values


def run_choices(scene: Scene, methods: "Sequence[str] | None", profile: str | None, variant: str | None,
                seed_peak: float | None = None,
                snapshots: Sequence[int] = ()) -> tuple[tuple[str, ...], str, str, tuple[int, ...]]:
    """A run's methods, profile and variant (names the scene file accepts, the closest one named
    otherwise; None: the scene's), its seed peak (within the peaks of the velocities a run takes) and snapshot contacts (integers within
    the scene's contacts, with the DNS among the methods), checked where the input enters
    (``pulsemap.run``, ``pulsemap run``); returns (methods, profile, variant, snapshots), or a
    one-line RunError (a ValueError). The types were checked by the caller."""
    from pulsemap.solvers.data.scene import METHODS, PROFILES, VARIANTS, SceneError, check_choice
    from pulsemap.solvers.studies.methods import RunError

    if seed_peak is not None and not (math.isfinite(seed_peak) and seed_peak > 0):
        raise RunError(f"seed peak must be a finite number > 0, got {seed_peak!r}")
    if seed_peak is not None:
        from pulsemap.solvers.chain.scaling import VELOCITY_RANGE

        lo, hi = (v ** (2.0 / (scene.exponent + 1.0)) for v in VELOCITY_RANGE)  # strains scale as v0^(2/(n+1))
        if not lo <= seed_peak <= hi:
            raise RunError(f"seed peak {seed_peak:g} is beyond the range {lo:.3g} <= peak <= {hi:.3g} a chain of n = "
                           f"{scene.exponent:g} carries (the peaks of v0 in [{VELOCITY_RANGE[0]:g}, "
                           f"{VELOCITY_RANGE[1]:g}], whose energy is a float64 number): give a peak within it")
    try:
        names = tuple(check_choice(m.strip(), "method", METHODS) for m in (scene.methods if methods is None else methods))
        profile = check_choice(profile or scene.profile, "profile", PROFILES)
        variant = check_choice(variant or scene.variant, "map variant", VARIANTS)
    except SceneError as exc:
        raise RunError(str(exc)) from None
    c0, c1 = scene.contacts
    for c in snapshots:
        if isinstance(c, bool) or not isinstance(c, int) or not c0 <= c <= c1:
            raise RunError(f"snapshot contact {c!r} must be an integer in the scene's contacts {c0}..{c1}")
    if snapshots and "dns" not in names:
        raise RunError("snapshots are taken by the DNS: add dns to the methods")
    momentum = [m for m in names if m.startswith("momentum")]
    if momentum and getattr(scene, "contact", None) is not None:
        raise RunError(f"{momentum[0]} cannot take a contact-law term: contact forces are internal, so the chain's "
                       "momentum changes only through R; use energy-law or energy-map for P")
    return names, profile, variant, tuple(sorted(set(snapshots)))


def api_hint(message: str) -> str:
    """Rewrite command-line advice for a Python caller (``--param mu=VALUE`` -> ``mu=VALUE``)."""
    message = re.sub(r"--param (\w+)=VALUE", r"\1=VALUE as a keyword argument", message)
    return " ".join(message.split())
