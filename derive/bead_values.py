"""Per-bead values of parameters and expressions of the bead index i, evaluated with numpy for
beads 1..N (derive/perturbation.py's Perturbation.bead_values and rest_force)."""

from __future__ import annotations

import numbers
from functools import lru_cache
from typing import Any, Mapping

import numpy as np
import sympy

from pulsemap.symbolic.expression import symbol
from pulsemap.symbolic.param_values import IndexExpression, ParamValue, PerturbationError, RandomDraw

def _check_beads(beads: object) -> int:
    if isinstance(beads, bool) or not isinstance(beads, numbers.Integral) or int(beads) < 1:
        raise PerturbationError(f"beads must be a positive integer, got {beads!r}")
    return int(beads)


def _bead_values(name: str, value: ParamValue, beads: int) -> np.ndarray:
    if isinstance(value, float):
        return np.full(beads, value, dtype=np.float64)
    if isinstance(value, tuple):
        if len(value) != beads:
            raise PerturbationError(
                f"parameter '{name}' has {len(value)} per-bead values but the chain has {beads} beads: "
                f"give exactly {beads}"
            )
        return np.asarray(value, dtype=np.float64)
    if isinstance(value, RandomDraw):
        return value.values(beads)
    if isinstance(value, IndexExpression):
        return _evaluate(value.expr, {}, beads, f"parameter '{name}' = {value.text!r}")
    raise PerturbationError(f"parameter '{name}' has an unsupported value {value!r}")


@lru_cache(maxsize=64)
def _frozen_bead_values(name: str, value: ParamValue, beads: int) -> np.ndarray:
    """_bead_values, read-only and kept (a law's right-hand side reads a random draw's bead at every
    evaluation: drawing the chain again each time was most of the cost)."""
    arr = _bead_values(name, value, beads)
    arr.flags.writeable = False
    return arr


_NUMPY_FUNCTIONS = (
    (sympy.sin, np.sin),
    (sympy.cos, np.cos),
    (sympy.tan, np.tan),
    (sympy.exp, np.exp),
    (sympy.log, np.log),
    (sympy.tanh, np.tanh),
    (sympy.sinh, np.sinh),
    (sympy.cosh, np.cosh),
    (sympy.Abs, np.abs),
    (sympy.sign, np.sign),
    (sympy.Heaviside, lambda x: np.heaviside(x, 0.5)),
)


def _evaluate(expr: sympy.Expr, env: Mapping[sympy.Symbol, np.ndarray], beads: int, what: str) -> np.ndarray:
    """Evaluate an expression of i (and per-bead parameter arrays) for beads 1..beads."""
    index = np.arange(1, beads + 1, dtype=np.float64)
    full_env = {symbol("i"): index, **env}
    with np.errstate(all="ignore"):
        values = np.broadcast_to(_numeric(expr, full_env, what), (beads,)).astype(np.float64)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise PerturbationError(f"{what} is not finite (or not real) at bead {int(bad[0]) + 1}")
    return values


def _numeric(expr: sympy.Expr, env: Mapping[sympy.Symbol, np.ndarray], what: str) -> Any:
    if expr.is_Symbol:
        if expr in env:
            return env[expr]
        raise PerturbationError(f"{what} depends on {expr}, which has no per-bead value here")
    if expr.is_number:
        value = complex(sympy.N(expr))
        return value.real if value.imag == 0 else np.nan
    args = [_numeric(arg, env, what) for arg in expr.args]
    if expr.is_Add:
        return sum(args[1:], args[0])
    if expr.is_Mul:
        result = args[0]
        for arg in args[1:]:
            result = result * arg
        return result
    if expr.is_Pow:
        base = np.asarray(args[0], dtype=np.float64)
        return np.power(base, args[1])
    for sympy_func, numpy_func in _NUMPY_FUNCTIONS:
        if expr.func == sympy_func:
            return numpy_func(args[0])
    raise PerturbationError(f"{what}: cannot evaluate {expr.func.__name__} numerically")
