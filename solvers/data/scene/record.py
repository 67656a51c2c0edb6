"""A scene file's resolved form on disk, read back without sympy.

Parsing R goes through sympy (:mod:`pulsemap.symbolic.expression`), whose import and parse cost a
few tenths of a second per process. Once a scene file has been parsed and validated, its resolved
form (:meth:`Scene.as_dict`) and the facts a run needs about R (which parameters it uses, whether
it contains i or is zero, whether it is a polynomial in u, v) are kept in the pulsemap cache, keyed
by a hash of the scene's table in canonical form (keys sorted) and where it came from, so the same
scene read from its file or rebuilt with overrides (``--set``, ``pulsemap.scene(name, **kw)``) finds
the same record. Loading the same scene again builds the Scene from that record: its perturbation
is a :class:`CachedPerturbation`, which answers what a run asks from those facts and parses R with
sympy only when something needs the expression itself.

Scenes with a parameter given as an expression of i, a contact law's term or masses are not recorded
(their values are evaluated through sympy anyway).
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any, Mapping

from pulsemap.symbolic import __version__
from pulsemap.symbolic.cache import load, note_damaged, store
from pulsemap.symbolic.param_forms import ParamMap, RandomDraw, param_data
from pulsemap.solvers.data.scene.parse import check_recorded_scene
from pulsemap.solvers.data.scene.schema import SceneError
from pulsemap.solvers.data.scene.spec import Scene

if TYPE_CHECKING:  # pragma: no cover
    import numpy as np

NAMESPACE = "scenes"
FORMAT = 3  # the record's layout; a new one ignores older records (3: keyed by the table, R's polynomial fact)


def record_key(data: Mapping[str, Any], source: str) -> str | None:
    """What a record depends on: the scene's table in canonical form (JSON, keys sorted: a file's
    spacing, comments and key order do not matter), its source and the pulsemap version; None for a
    table JSON cannot hold exactly (a TOML date, a NaN): such a scene is parsed every time."""
    try:
        canonical = json.dumps(data, sort_keys=True, separators=(",", ":"), allow_nan=False)
    except (TypeError, ValueError):
        return None
    digest = hashlib.sha256(canonical.encode("utf-8")).hexdigest()
    return f"scene-record {FORMAT} {__version__} {source!r} {digest}"


@dataclass(frozen=True, eq=False)
class CachedPerturbation:
    """eps * R_i(u, v) of paper Eq. 1 from a scene record: what a run reads (text, eps, parameter
    values, used parameters, per-bead values) without sympy; anything else (the expression ``R``,
    derivations) from the Perturbation that :attr:`parsed` builds on first use."""

    text: str
    eps: float
    params: ParamMap  # floats, per-bead tuples, RandomDraws (no expressions of i)
    used_parameters: tuple[str, ...]
    uses_i: bool
    is_zero: bool
    is_polynomial: bool  # R is a polynomial in u, v (derive/perturbation.py: Perturbation.is_polynomial)

    @cached_property
    def parsed(self):
        """The full Perturbation (sympy), parsed once."""
        from pulsemap.symbolic.perturbation import make_perturbation

        return make_perturbation(self.text, self.eps, {k: param_data(v) for k, v in self.params.items()})

    @property
    def R(self):
        return self.parsed.R

    @property
    def unused_parameters(self) -> tuple[str, ...]:
        return tuple(name for name in self.params if name not in self.used_parameters)

    @property
    def site_dependent(self) -> tuple[str, ...]:
        return tuple(name for name in self.used_parameters if not isinstance(self.params[name], float))

    @property
    def is_uniform(self) -> bool:
        return not self.uses_i and not self.site_dependent

    @property
    def acts(self) -> bool:
        """As Perturbation.acts, from the record's own fields (no sympy)."""
        return not (self.is_zero or self.eps == 0)

    def bead_values(self, name: str, beads: int) -> np.ndarray:
        """Values of parameter ``name`` for beads 1..beads, float64 (as Perturbation.bead_values)."""
        import numpy as np

        value = self.params.get(name)
        if isinstance(value, float):
            return np.full(beads, value, dtype=np.float64)
        if isinstance(value, RandomDraw):
            return value.values(beads)
        if isinstance(value, tuple) and len(value) == beads:
            return np.asarray(value, dtype=np.float64)
        return self.parsed.bead_values(name, beads)  # the error, worded by the symbolic side

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__") or name == "parsed":
            raise AttributeError(name)
        return getattr(self.parsed, name)

    def __eq__(self, other: object) -> bool:
        if not all(hasattr(other, a) for a in ("text", "eps", "params")):
            return NotImplemented
        return (self.text, self.eps, self.params) == (other.text, other.eps, other.params)

    def __hash__(self) -> int:
        return hash((self.text, self.eps, self.params))


def _param_value(data: Any) -> Any:
    if isinstance(data, dict):
        return RandomDraw(float(data["uniform"][0]), float(data["uniform"][1]), int(data["seed"]))
    if isinstance(data, list):
        return tuple(float(x) for x in data)
    return float(data)


def recorded_scene(data: Mapping[str, Any], source: str) -> Scene:
    """The Scene of a scene table (a decoded file, or a scene's table with overrides applied): its
    record when this table was parsed before (no sympy), else parsed and validated by ``parse_scene``
    (the one place scene input is checked) and recorded."""
    from pulsemap.solvers.data.scene.parse import parse_scene

    key = record_key(data, source)
    scene = None if key is None else load_record(key)
    if scene is None:
        scene = parse_scene(data, source)
        if key is not None:
            save_record(key, scene)
    return scene


def load_record(key: str) -> Scene | None:
    """The Scene recorded under ``key`` (:func:`record_key`), or None (no record yet, or an unreadable one)."""
    try:
        value = load(NAMESPACE, key, _check, quiet=True)
    except OSError:  # no usable cache directory: parse the scene as without one
        value = None
    if value is None:
        return None
    d, facts = value["scene"], value["facts"]
    try:  # a record is re-validated as the scene file would be: a forged one is read as damaged
        fields = check_recorded_scene(d)
    except SceneError as exc:
        note_damaged(NAMESPACE, key, f"refused as a scene file would be: {exc}")
        return None
    pert = d["perturbation"]
    return Scene(
        **fields,
        perturbation=CachedPerturbation(
            text=pert["R"], eps=float(pert["eps"]),
            params=ParamMap.of({k: _param_value(v) for k, v in pert["params"].items()}),
            used_parameters=tuple(facts["used_parameters"]), uses_i=bool(facts["uses_i"]),
            is_zero=bool(facts["is_zero"]), is_polynomial=bool(facts["is_polynomial"])),
    )


def save_record(key: str, scene: Scene) -> None:
    """Record a parsed, validated scene (not one with an expression of i; a cache that cannot be
    written is skipped: the record only saves time)."""
    from pulsemap.symbolic.expression import symbol

    pert = scene.perturbation
    if not all(isinstance(v, (float, tuple, RandomDraw)) for v in pert.params.values()):
        return
    if scene.contact is not None or scene.masses is not None:  # their tables are evaluated through sympy anyway
        return
    facts = {"used_parameters": list(pert.used_parameters), "uses_i": symbol("i") in pert.R.free_symbols,
             "is_zero": bool(pert.is_zero), "is_polynomial": bool(pert.is_polynomial)}
    try:
        store(NAMESPACE, key, {"scene": scene.as_dict(), "facts": facts})
    except OSError:
        pass


def _check(value: Any) -> str | None:
    """What is wrong with a record read back (None: nothing)."""
    try:
        d, facts = value["scene"], value["facts"]
        numbers = [d["chain"]["exponent"], d["excitation"]["velocity"], d["perturbation"]["eps"]]
        used = facts["used_parameters"]
        ok = (all(isinstance(x, (int, float)) and math.isfinite(x) for x in numbers)
              and isinstance(d["perturbation"]["R"], str) and isinstance(used, list)
              and all(isinstance(p, str) and p in d["perturbation"]["params"] for p in used)
              and isinstance(facts["uses_i"], bool) and isinstance(facts["is_zero"], bool)
              and isinstance(facts["is_polynomial"], bool))
    except (KeyError, TypeError, IndexError):
        return "not a scene record"
    return None if ok else "not a scene record"
