"""The sympy-free forms of a parameter value (docs/perturbation.rst, "Parameters") and the one
per-bead random draw every side uses: the symbolic layer (param_values.py), the DNS force and the
sweep workers (solvers/models/chain_build.py) must agree bit for bit, so there is one function."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Mapping

from pulsemap.symbolic.frozenmap import FrozenMap

if TYPE_CHECKING:  # pragma: no cover
    import numpy as np


@dataclass(frozen=True)
class RandomDraw:
    """Per-bead values drawn from ``default_rng(seed).uniform(low, high, size=beads)``."""

    low: float
    high: float
    seed: int
    distribution: str = "uniform"

    def values(self, beads: int) -> np.ndarray:
        """The draw for beads 1..beads, shape (beads,), float64 (bead k is element k-1)."""
        return uniform_draw(self.low, self.high, self.seed, beads)


def uniform_draw(low: float, high: float, seed: int, beads: int) -> np.ndarray:
    """``numpy.random.default_rng(seed).uniform(low, high, size=beads)`` as float64: the per-bead random
    draw of a parameter (paper Eqs. 43-44's random foundation)."""
    import numpy as np  # here: importing pulsemap stays free of numpy

    return np.random.default_rng(int(seed)).uniform(float(low), float(high), size=int(beads)).astype(np.float64)


def param_data(value: object) -> object:
    """A parameter value back in the form a scene file gives it (the inverse of param_values.parse_param_value):
    a number, a list, ``{"uniform": [low, high], "seed": s}``, or an expression of i as its text."""
    if isinstance(value, RandomDraw):
        return {value.distribution: [value.low, value.high], "seed": value.seed}
    if isinstance(value, tuple):
        return list(value)
    return getattr(value, "text", value)  # an IndexExpression: its text


@dataclass(frozen=True)
class ParamMap(FrozenMap):
    """An immutable, hashable mapping from parameter names to values (sorted by name)."""

    @classmethod
    def of(cls, mapping: Mapping[str, object]) -> "ParamMap":
        return cls(tuple(sorted(mapping.items())))

    def __repr__(self) -> str:
        return "ParamMap(" + repr(dict(self.items_)) + ")"
