"""Scene files: a chain, an excitation, a perturbation and what to report (DESIGN.md, "Scene file").

A scene is TOML data, parsed with :mod:`tomllib` and validated here; nothing in it is ever
executed (R is parsed by :mod:`pulsemap.derive.expression`'s whitelisting parser). Every problem is a
:class:`SceneError` with a one-line message naming the file or scene, the problem and the fix.

    name = "damping-eps0.3"
    [chain]                 # optional table
    beads = 140             # N; omit to let the DNS size the chain from the contacts
    exponent = 1.5          # n (default 1.5)
    first_perturbed = 16    # bead where R starts (default 16)
    [excitation]
    velocity = 1.0          # v0 of bead 1
    [perturbation]
    R = "-mu*v"
    eps = 0.3
    [perturbation.params]
    mu = 1.0                # or a list of N per-bead values, {uniform = [0, 1], seed = 7}, "1 + 0.01*i"
    [output]
    contacts = [16, 120]    # first and last contact reported (1-based, inclusive)
    methods = ["map", "longwave", "dns"]
    [model]                 # optional: profile "exact" | "pade", variant "paper" | "corrected" | "1d"
    [dns]                   # optional: rtol (1e-10), atol (1e-12), method ("auto")

Built-in scenes (the paper's figures) live in ``solvers/data/scenes/*.toml``; ``default`` is an alias
of :data:`DEFAULT_SCENE`. ``pulsemap.derive.perturbation`` pulls in sympy, so it is imported lazily:
``import pulsemap.solvers.data.scene`` stays light.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import numbers
import re
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10 (pyproject pulls in tomli)
    import tomli as tomllib  # type: ignore[no-redef]

from pulsemap.derive.frozenmap import FrozenMap

if TYPE_CHECKING:  # pragma: no cover
    from pulsemap.derive.perturbation import Perturbation

__all__ = [
    "DEFAULT_SCENE",
    "DNS_DEFAULTS",
    "METHODS",
    "FrozenMap",
    "Scene",
    "SceneError",
    "builtin_scene_path",
    "builtin_scenes",
    "check_choice",
    "load_scene",
    "parse_scene",
]

METHODS = ("map", "longwave", "energy-map", "energy-law", "momentum-map", "momentum-law", "dns")
"""The ways a scene can be computed, in canonical order (balance models: derive/balance.py)."""
DEFAULT_METHODS = ("map", "longwave", "dns")
"""What a scene without [output] methods computes."""
PROFILES = ("exact", "pade")
VARIANTS = ("paper", "corrected", "1d")
DNS_METHODS = ("auto", "DOP853", "RK45", "Radau", "BDF", "LSODA")
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
    "dns": ("rtol", "atol", "method"),
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


def _default_dns() -> FrozenMap:
    return FrozenMap(tuple(DNS_DEFAULTS.items()))


@dataclass(frozen=True)
class Scene:
    """A resolved, validated scene. Build it with :func:`load_scene` or :func:`parse_scene`."""

    name: str
    beads: int | None  # None: the chain is as long as the contacts need (the DNS picks it)
    exponent: float  # n
    first_perturbed: int  # bead where R starts (paper: 16)
    velocity: float  # v0 of bead 1
    perturbation: "Perturbation"  # R, eps, params (pulsemap.derive.perturbation)
    contacts: tuple[int, int]  # first and last contact reported (1-based, inclusive)
    methods: tuple[str, ...]  # subset of METHODS, in canonical order
    profile: str = "exact"  # "exact" | "pade"
    variant: str = "paper"  # "paper" | "corrected" | "1d"
    dns: Mapping[str, Any] = dataclasses.field(default_factory=_default_dns)
    source: str = ""  # path or "builtin:NAME"

    def as_dict(self) -> dict:
        """The scene as resolved, JSON-serialisable, in the layout of a scene file.

        R is its text, parameters are in their input form (numbers, per-bead lists, random
        draws as ``{"uniform": [lo, hi], "seed": s}``, expressions of i as text) and every
        default is filled in; ``beads`` is null when unset. ``parse_scene(d, source)`` of the
        result gives back an equal scene (``source`` in the dict is informational).
        """
        from pulsemap.derive.perturbation import param_data  # lazily: pulsemap.derive.perturbation imports sympy

        pert = self.perturbation
        return {
            "name": self.name,
            "source": self.source,
            "chain": {
                "beads": self.beads,
                "exponent": self.exponent,
                "first_perturbed": self.first_perturbed,
            },
            "excitation": {"velocity": self.velocity},
            "perturbation": {
                "R": pert.text,
                "eps": pert.eps,
                "params": {name: param_data(value) for name, value in pert.params.items()},
            },
            "output": {"contacts": list(self.contacts), "methods": list(self.methods)},
            "model": {"profile": self.profile, "variant": self.variant},
            "dns": dict(self.dns),
        }

    def with_overrides(self, **kw: Any) -> "Scene":
        """A copy with some fields replaced, validated like a scene file.

        Keys are the field names; also ``R``, ``eps`` and ``params`` (raw values, as in a scene
        file) to rebuild the perturbation (a new ``R`` without ``params`` keeps the current
        parameters it uses and drops the others). ``dns`` is merged over the current DNS options.
        """
        fields = {f.name for f in dataclasses.fields(self)}
        allowed = sorted(fields | {"R", "eps", "params"})
        for key in kw:
            if key not in allowed:
                raise SceneError(_prefix(self.source, self.name) + _unknown(key, allowed, "in with_overrides()"))
        values = {name: getattr(self, name) for name in fields}
        try:
            raw = {key: value for key, value in kw.items() if key in fields}
            if "dns" in raw:
                raw["dns"] = _check_dns_table({**dict(self.dns), **_as_table(raw["dns"], "dns")})
            if {"R", "eps", "params"} & kw.keys():
                if "perturbation" in kw:
                    raise _Problem("give either perturbation or R/eps/params, not both")
                data = self.as_dict()["perturbation"]
                data.update({key: kw[key] for key in ("R", "eps", "params") if key in kw})
                raw["perturbation"] = _build_perturbation(data, self.name, drop_unused="params" not in kw)
            values.update(_check_fields(raw))
            scene = Scene(**values)
            _check_consistency(scene)
        except _Problem as exc:
            raise SceneError(_prefix(self.source, values.get("name", self.name)) + str(exc)) from None
        return scene


# --------------------------------------------------------------------------- loading


def builtin_scenes() -> list[str]:
    """Names of the built-in scenes, sorted (the alias ``default`` is not listed)."""
    folder = resources.files("pulsemap.solvers.data").joinpath("scenes")
    return sorted(entry.name[: -len(".toml")] for entry in folder.iterdir() if entry.name.endswith(".toml"))


def builtin_scene_path(name: str):
    """The packaged TOML file of built-in scene ``name`` (an importlib.resources Traversable)."""
    resolved = ALIASES.get(name, name)
    names = builtin_scenes()
    if resolved not in names:
        raise SceneError(
            f"unknown built-in scene {name!r}{_suggest(name, names + list(ALIASES))}: "
            f"choose one of {', '.join(names)} or default"
        )
    return resources.files("pulsemap.solvers.data").joinpath("scenes", f"{resolved}.toml")


def load_scene(ref: str | Path) -> Scene:
    """Load a scene from a path to a ``.toml`` file or from the name of a built-in scene."""
    text = str(ref)
    looks_like_path = isinstance(ref, Path) or text.endswith(".toml") or "/" in text or "\\" in text
    if not looks_like_path and (text in ALIASES or text in builtin_scenes()):
        resolved = ALIASES.get(text, text)
        source = f"builtin:{resolved}"
        return parse_scene(_decode(builtin_scene_path(resolved).read_bytes(), source), source)
    path = Path(text).expanduser()
    if path.is_dir():
        raise SceneError(f"{text}: is a directory, not a scene file: give the path of a .toml file in it")
    if not path.exists():
        names = builtin_scenes() + list(ALIASES)
        stem = path.name[: -len(".toml")] if path.name.endswith(".toml") else path.name
        close = difflib.get_close_matches(stem, names, n=1)
        hint = f" (did you mean the built-in scene '{close[0]}'?)" if close else ""
        raise SceneError(
            f"scene file {text!r} not found{hint}: give the path of a .toml file or a built-in "
            "name (pulsemap scenes lists them)"
        )
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise SceneError(f"{text}: cannot read the scene file ({exc.strerror or exc}): check its permissions") from None
    return parse_scene(_decode(data, text), text)


def _decode(data: bytes, source: str) -> dict:
    try:
        return tomllib.loads(data.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise SceneError(
            f"{source}: not UTF-8 text (byte {exc.start}): save the scene file as UTF-8 TOML"
        ) from None
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{source}: {_toml_reason(str(exc))}") from None


def _toml_reason(message: str) -> str:
    """'Invalid value (at line 3, column 5)' -> 'TOML syntax error at line 3, column 5: ...'."""
    message = " ".join(message.split())
    match = re.match(r"(.*?)\s*\(at (line \d+, column \d+)\)\s*$", message)
    if match:
        return (
            f"TOML syntax error at {match.group(2)}: {match.group(1)}: fix the syntax "
            '(strings in quotes, e.g. R = "-mu*v"; arrays as [16, 120])'
        )
    return f"TOML syntax error: {message}: fix the syntax"


# --------------------------------------------------------------------------- parsing


def parse_scene(data: Mapping[str, Any], source: str) -> Scene:
    """Validate an already-parsed TOML table (or :meth:`Scene.as_dict`) and return the Scene."""
    source = str(source)
    name = _default_name(source)
    try:
        if not isinstance(data, Mapping):
            raise _Problem(f"a scene must be a table of tables, got {_type_name(data)}")
        if "name" in data:
            name = _check_name(data["name"])
        _check_structure(data)
        tables = {key: _as_table(data.get(key, {}), key) for key in _TABLES}
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
        fields["perturbation"] = _build_perturbation(tables["perturbation"], name)
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


def _prefix(source: str, name: str) -> str:
    if not source or source == f"builtin:{name}":
        return f"scene '{name}': "
    return f"{source} (scene '{name}'): "


def _check_structure(data: Mapping[str, Any]) -> None:
    """Unknown tables and keys (with suggestions), tables given as values, missing keys."""
    for key, value in data.items():
        if key not in _SCHEMA[""]:
            if isinstance(value, Mapping):
                raise _Problem(
                    f"unknown table [{key}]{_suggest(key, _TABLES, '[', ']')}: "
                    f"known tables are {', '.join(f'[{t}]' for t in _TABLES)}"
                )
            raise _Problem(_unknown(key, _SCHEMA[""], "at the top level"))
    for table in _TABLES:
        if table not in data:
            if table in _REQUIRED_TABLES:
                key = _REQUIRED_KEYS[table][0]
                raise _Problem(
                    f"missing table [{table}]: add it with at least "
                    f"{_EXAMPLES.get(f'{table}.{key}', key + ' = ...')}"
                )
            continue
        content = _as_table(data[table], table)
        for key, value in content.items():
            if key not in _SCHEMA[table]:
                if isinstance(value, Mapping):
                    raise _Problem(
                        f"unknown table [{table}.{key}]{_suggest(key, _SCHEMA[table], f'[{table}.', ']')}: "
                        f"[{table}] holds {', '.join(_SCHEMA[table])}"
                    )
                if key in _SCHEMA[""]:
                    raise _Problem(
                        f"key {key!r} is inside [{table}] but belongs at the top level: move it above "
                        f"the first table header{' or write [' + key + '] on its own line' if key in _TABLES else ''}"
                    )
                raise _Problem(_unknown(key, _SCHEMA[table], f"in [{table}]"))
        for key in _REQUIRED_KEYS.get(table, ()):
            if key not in content:
                raise _Problem(
                    f"missing key {key!r} in [{table}]: add {_EXAMPLES.get(f'{table}.{key}', key + ' = ...')}"
                )
    params = _as_table(data["perturbation"], "perturbation").get("params", {})
    if not isinstance(params, Mapping):
        raise _Problem(
            f"[perturbation] params must be a table [perturbation.params] of NAME = VALUE, got {_type_name(params)}"
        )


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


# --------------------------------------------------------------------------- field checks


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
    result = float(value)
    if not math.isfinite(result):
        raise _Problem(f"{key} = {result} is not finite: give a finite number")
    return result


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
    from pulsemap.derive.profile import ProfileError, check_exponent

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
        values[key] = tol
    values["method"] = _check_choice(table["method"], "[dns] method", DNS_METHODS)
    return FrozenMap(tuple(values.items()))


# --------------------------------------------------------------------------- perturbation


def _build_perturbation(table: Mapping[str, Any], name: str, drop_unused: bool = False) -> "Perturbation":
    """make_perturbation(R, eps, params), its errors as one-line problems.

    Every parameter given must occur in R (check_all_used); ``drop_unused`` instead drops the
    ones R does not use (with_overrides(R=...) keeping the old parameters).
    """
    from pulsemap.derive.expression import ExpressionError
    from pulsemap.derive.perturbation import PerturbationError, check_all_used, make_perturbation

    R = table["R"]
    if not isinstance(R, str):
        raise _Problem(f"[perturbation] R must be a string formula in u, v, i and parameters, got {_type_name(R)}: e.g. R = \"-mu*v\"")
    eps = _number(table["eps"], "[perturbation] eps")
    params = table.get("params") or {}
    if not isinstance(params, Mapping):
        raise _Problem(f"[perturbation] params must be a table of NAME = VALUE, got {_type_name(params)}")
    try:
        pert = make_perturbation(R, eps, dict(params))
        if drop_unused and pert.unused_parameters:
            used = {key: value for key, value in params.items() if key not in pert.unused_parameters}
            pert = make_perturbation(R, eps, used)
        return check_all_used(pert)
    except (PerturbationError, ExpressionError) as exc:
        raise _Problem("[perturbation] " + _scene_hint(str(exc))) from None


def _check_perturbation_object(value: Any) -> "Perturbation":
    from pulsemap.derive.perturbation import Perturbation

    if not isinstance(value, Perturbation):
        raise _Problem(f"perturbation must be a pulsemap.derive.perturbation.Perturbation, got {_type_name(value)}: or pass R, eps, params")
    return value


def _scene_hint(message: str) -> str:
    """Rewrite command-line advice for a scene file; keep the message on one line."""
    message = re.sub(r"--param (\w+)=VALUE", r"\1 = VALUE under [perturbation.params]", message)
    return " ".join(message.split())


# --------------------------------------------------------------------------- cross-checks


def _check_consistency(scene: Scene) -> None:
    """Checks that involve several fields: chain length, contacts, first_perturbed, per-bead values."""
    from pulsemap.derive.perturbation import PerturbationError, RandomDraw

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
        for pname in pert.params:
            pert.bead_values(pname, scene.beads)
        pert.check_at_rest(scene.beads)
    except PerturbationError as exc:
        raise _Problem("[perturbation] " + _scene_hint(str(exc))) from None
