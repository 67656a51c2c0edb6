"""The scene file format: tables, keys, defaults and choices; SceneError and the message helpers.

What a scene file may hold (see :mod:`pulsemap.solvers.data.scene` for an example) and the
shared pieces of its one-line error messages. No sympy here.
"""

from __future__ import annotations

import difflib
import math
import numbers
from typing import Any, Mapping

METHODS = ("map", "longwave", "energy-map", "energy-law", "momentum-map", "momentum-law", "relaxed", "dressed-law",
           "dns")
"""The ways a scene can be computed, in canonical order (balance models: derive/balance.py; relaxed:
solvers/models/relaxed.py; dressed-law: solvers/studies/dressed.py)."""
DEFAULT_METHODS = ("map", "longwave", "dns")
"""What a scene without [output] methods computes."""
PROFILES = ("exact", "pade")
VARIANTS = ("paper", "corrected", "1d")
DNS_METHODS = ("auto", "DOP853", "RK45", "Radau", "BDF", "LSODA")
DNS_ENGINES = ("compiled", "scipy")  # [dns] engine, optional (absent: "compiled" where it applies)
DNS_MODES = ("window", "full")  # [dns] mode, optional (absent: "window", the moving window of chain/window.py)
DNS_DEFAULTS: Mapping[str, Any] = {"rtol": 1e-10, "atol": 1e-12, "method": "auto"}
DEFAULT_SCENE = "fig8-eps0.3"
"""What ``load_scene("default")`` returns: linear damping, cheap, the quick start's main job."""
ALIASES = {"default": DEFAULT_SCENE}
DEFAULT_FIRST_PERTURBED = 16
DEFAULT_EXPONENT = 1.5
MAX_BEADS = 1_000_000

# Keys allowed in each table; None marks a sub-table.
_SCHEMA: dict[str, tuple[str, ...]] = {
    "": ("name", "source", "chain", "excitation", "perturbation", "output", "model", "dns"),
    "chain": ("beads", "exponent", "first_perturbed"),
    "excitation": ("velocity",),
    "perturbation": ("R", "eps", "params"),
    "output": ("contacts", "methods"),
    "model": ("profile", "variant"),
    "dns": ("rtol", "atol", "method", "engine", "mode"),
}
_TABLES = ("chain", "excitation", "perturbation", "output", "model", "dns")
_REQUIRED_TABLES = ("excitation", "perturbation", "output")
_REQUIRED_KEYS = {"excitation": ("velocity",), "perturbation": ("R", "eps"), "output": ("contacts",)}
_EXAMPLES = {
    "excitation.velocity": "velocity = 1.0",
    "perturbation.R": 'R = "-mu*v"',
    "perturbation.eps": "eps = 0.1",
    "output.contacts": "contacts = [16, 120]",
}


class SceneError(ValueError):
    """A scene file or scene value was rejected; the one-line message says why and what to do."""


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
    return f"unknown key {key!r} {where}{_suggest(key, known)}; known keys: {', '.join(known)}"


def _suggest(word: object, known: tuple[str, ...] | list[str], left: str = "'", right: str = "'") -> str:
    word = str(word)
    lower = {k.lower(): k for k in known}
    close = [lower[word.lower()]] if word.lower() in lower else difflib.get_close_matches(word, list(known), n=1)
    return f" (did you mean {left}{close[0]}{right}?)" if close else ""


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
