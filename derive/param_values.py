"""Values of the perturbation's parameters (docs/perturbation.rst, "Parameters"): a scalar, a per-bead list, a
seeded uniform draw or an expression of the bead index i; parsed from scene, TOML and command-line
forms with one-line errors naming the parameter, and evaluated with numpy for beads 1..N
(derive/perturbation.py's Perturbation.bead_values and rest_force)."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Mapping, Union

import numpy as np
import sympy

from pulsemap.symbolic.errors import PulsemapError, closest
from pulsemap.symbolic.expression import ExpressionError, check_parameter_name, parse_expression, symbol
from pulsemap.symbolic.param_forms import ParamMap, RandomDraw, param_data  # noqa: F401 (their home; names kept here)

class PerturbationError(PulsemapError):
    """A perturbation or one of its parameter values was rejected; the message says why."""


DRAW_KEYS = ("uniform", "seed")


_DRAW_EXAMPLE = "{uniform = [0, 1], seed = 7}"


_VALUE_FORMS = (
    "a number, a list of per-bead numbers, " + _DRAW_EXAMPLE + " or an expression of i"
)


@dataclass(frozen=True)
class IndexExpression:
    """Per-bead values given by a formula of the bead index ``i`` (1-based)."""

    text: str
    expr: sympy.Expr


ParamValue = Union[float, tuple[float, ...], RandomDraw, IndexExpression]


def parse_param_value(name: str, raw: object) -> ParamValue:
    """A parameter value from a scene/TOML/CLI value (see the module docstring for the forms)."""
    check_name(name)
    if raw is None:
        raise PerturbationError(f"parameter '{name}' has no value: give {_VALUE_FORMS}")
    if isinstance(raw, bool) or isinstance(raw, np.bool_):
        raise PerturbationError(f"parameter '{name}' = {raw} is a boolean: give a number")
    if isinstance(raw, RandomDraw):
        return _check_draw(name, raw.low, raw.high, raw.seed, raw.distribution)
    if isinstance(raw, IndexExpression):
        return _index_expression(name, raw.text)
    if isinstance(raw, numbers.Real):
        return finite_float(f"parameter '{name}'", raw)
    if isinstance(raw, str):
        return _parse_string_value(name, raw)
    if isinstance(raw, Mapping):
        return _parse_draw(name, raw)
    if isinstance(raw, (list, tuple, np.ndarray)):
        return _parse_list(name, raw)
    raise PerturbationError(
        f"parameter '{name}' has a value of unsupported type {type(raw).__name__}: give {_VALUE_FORMS}"
    )


def parse_cli_param(text: str) -> tuple[str, ParamValue]:
    """Parse a command-line ``NAME=VALUE`` (VALUE: number, comma list, or expression of i)."""
    if not isinstance(text, str) or "=" not in text:
        raise PerturbationError(
            f"--param expects NAME=VALUE (e.g. mu=0.5, k=1,2,3 or k=1+0.01*i), got {text!r}"
        )
    name, _, value = text.partition("=")
    name = name.strip()
    check_name(name)
    if not value.strip():
        raise PerturbationError(f"parameter '{name}' has no value: write {name}=VALUE")
    return name, parse_param_value(name, value)


def check_name(name: object) -> None:
    try:
        check_parameter_name(name)
    except ExpressionError as exc:
        raise PerturbationError(str(exc)) from exc


def finite_float(what: str, raw: object) -> float:
    if isinstance(raw, (bool, np.bool_)):
        raise PerturbationError(f"{what} = {raw} is a boolean: give a number")
    if not isinstance(raw, numbers.Real):
        raise PerturbationError(f"{what} = {raw!r} is not a number")
    try:
        value = float(raw)
    except OverflowError:  # an integer of hundreds of digits
        raise PerturbationError(f"{what} = {str(raw)[:12]}... ({len(str(raw))} digits) is beyond float64 "
                                "(about 1.8e308): give a finite number") from None
    if not math.isfinite(value):
        raise PerturbationError(f"{what} = {value} is not finite: give a finite number")
    return value


def to_float(expr: sympy.Expr, what: str) -> float:
    value = complex(sympy.N(expr))
    if value.imag != 0 or not math.isfinite(value.real):
        raise PerturbationError(f"{what} = {expr} is not a finite real number")
    return value.real


def exact(value: float) -> sympy.Rational:
    """The shortest decimal that round-trips ``value``, as an exact Rational (0.1 -> 1/10)."""
    return sympy.Rational(repr(float(value)))


def is_scalar(value: ParamValue) -> bool:
    return isinstance(value, float)


def value_kind(value: ParamValue) -> str:
    if isinstance(value, tuple):
        return f"a per-bead list of {len(value)} values"
    if isinstance(value, RandomDraw):
        return f"a random draw (seed {value.seed})"
    if isinstance(value, IndexExpression):
        return f"an expression of i ({value.text})"
    return "a scalar"


def _parse_string_value(name: str, raw: str) -> ParamValue:
    text = raw.strip()
    if not text:
        raise PerturbationError(f"parameter '{name}' has no value: give {_VALUE_FORMS}")
    if "," in text:
        items = [item.strip() for item in text.split(",")]
        return _parse_list(name, [_constant(name, item, k) for k, item in enumerate(items)])
    return _index_expression(name, text)


def _constant(name: str, text: str, position: int) -> float:
    where = f"parameter '{name}' element {position + 1}"
    if not text:
        raise PerturbationError(f"{where} is empty (stray ',' in the list)")
    try:
        expr = parse_expression(text, symbols=())
    except ExpressionError as exc:
        raise PerturbationError(f"{where}: {exc}") from exc
    if expr.free_symbols:
        raise PerturbationError(f"{where} = {text!r} must be a number in a list of per-bead values")
    return to_float(expr, where)


def _index_expression(name: str, text: str) -> ParamValue:
    try:
        expr = parse_expression(text, symbols=("i",))
    except ExpressionError as exc:
        raise PerturbationError(f"parameter '{name}': {exc}") from exc
    others = sorted(s.name for s in expr.free_symbols if s.name != "i")
    if others:
        raise PerturbationError(
            f"parameter '{name}' = {text!r} may depend only on the bead index i, not on {', '.join(others)}"
        )
    if not expr.free_symbols:
        return finite_float(f"parameter '{name}'", to_float(expr, f"parameter '{name}'"))
    return IndexExpression(text=text.strip(), expr=expr)


def _parse_list(name: str, raw: Any) -> tuple[float, ...]:
    if isinstance(raw, np.ndarray) and raw.ndim != 1:
        raise PerturbationError(f"parameter '{name}' per-bead values must be a flat list, got shape {raw.shape}")
    items = list(raw)
    if not items:
        raise PerturbationError(f"parameter '{name}' is an empty list: give one value per bead")
    values = []
    for k, item in enumerate(items):
        if isinstance(item, (bool, np.bool_)) or not isinstance(item, numbers.Real):
            raise PerturbationError(
                f"parameter '{name}' element {k + 1} = {item!r} is not a number "
                "(per-bead lists hold numbers only)"
            )
        values.append(finite_float(f"parameter '{name}' element {k + 1}", item))
    return tuple(values)


def _parse_draw(name: str, raw: Mapping) -> RandomDraw:
    for key in raw:
        if key not in DRAW_KEYS:
            close = closest(str(key), DRAW_KEYS)
            hint = f"did you mean '{close}'? " if close else ""
            raise PerturbationError(
                f"parameter '{name}': unknown random-draw key {str(key)!r}: {hint}"
                f"use {_DRAW_EXAMPLE}"
            )
    if "uniform" not in raw:
        raise PerturbationError(f"parameter '{name}': a random draw needs uniform = [low, high], e.g. {_DRAW_EXAMPLE}")
    if "seed" not in raw:
        raise PerturbationError(
            f"parameter '{name}': random draws need a seed for reproducibility: {_DRAW_EXAMPLE}"
        )
    bounds = raw["uniform"]
    if isinstance(bounds, (str, Mapping)) or not hasattr(bounds, "__len__") or len(bounds) != 2:
        raise PerturbationError(f"parameter '{name}': uniform must be [low, high], got {bounds!r}")
    return _check_draw(name, bounds[0], bounds[1], raw["seed"], "uniform")


def _check_draw(name: str, low: object, high: object, seed: object, distribution: str) -> RandomDraw:
    if distribution != "uniform":
        raise PerturbationError(f"parameter '{name}': only uniform random draws are supported, got {distribution!r}")
    lo = finite_float(f"parameter '{name}' uniform low", low)
    hi = finite_float(f"parameter '{name}' uniform high", high)
    if lo > hi:
        raise PerturbationError(f"parameter '{name}': uniform = [{lo}, {hi}] has low > high; swap them")
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, numbers.Integral) or int(seed) < 0:
        raise PerturbationError(
            f"parameter '{name}': seed must be a non-negative integer, got {seed!r} (e.g. {_DRAW_EXAMPLE})"
        )
    return RandomDraw(low=lo, high=hi, seed=int(seed), distribution="uniform")


def check_beads(beads: object) -> int:
    if isinstance(beads, bool) or not isinstance(beads, numbers.Integral) or int(beads) < 1:
        raise PerturbationError(f"beads must be a positive integer, got {beads!r}")
    return int(beads)


def values_per_bead(name: str, value: ParamValue, beads: int) -> np.ndarray:
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
        return evaluate_per_bead(value.expr, {}, beads, f"parameter '{name}' = {value.text!r}")
    raise PerturbationError(f"parameter '{name}' has an unsupported value {value!r}")


@lru_cache(maxsize=64)
def frozen_values_per_bead(name: str, value: ParamValue, beads: int) -> np.ndarray:
    """values_per_bead, read-only and kept (a law's right-hand side reads a random draw's bead at every
    evaluation: drawing the chain again each time was most of the cost)."""
    arr = values_per_bead(name, value, beads)
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


def evaluate_per_bead(expr: sympy.Expr, env: Mapping[sympy.Symbol, np.ndarray], beads: int, what: str) -> np.ndarray:
    """Evaluate an expression of i (and per-bead parameter arrays) for beads 1..beads."""
    index = np.arange(1, beads + 1, dtype=np.float64)
    full_env = {symbol("i"): index, **env}
    with np.errstate(all="ignore"):
        values = np.broadcast_to(numeric_value(expr, full_env, what), (beads,)).astype(np.float64)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise PerturbationError(f"{what} is not finite (or not real) at bead {int(bad[0]) + 1}")
    return values


def numeric_value(expr: sympy.Expr, env: Mapping[sympy.Symbol, np.ndarray], what: str) -> Any:
    if expr.is_Symbol:
        if expr in env:
            return env[expr]
        raise PerturbationError(f"{what} depends on {expr}, which has no per-bead value here")
    if expr.is_number:
        value = complex(sympy.N(expr))
        return value.real if value.imag == 0 else np.nan
    args = [numeric_value(arg, env, what) for arg in expr.args]
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
