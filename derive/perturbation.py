"""The on-site perturbation eps * R_i(u, v) of paper Eq. 1 and the values of its parameters.

``R`` is a sympy expression in ``u`` (x_i), ``v`` (x_i'), ``i`` (1-based bead index) and named
parameters. A parameter value is one of (docs/perturbation.rst, "Parameters"):

* a scalar (float), the same for every bead;
* a tuple of N per-bead values (bead k is element k-1);
* a :class:`RandomDraw` ``{uniform = [low, high], seed = s}``: the per-bead values are
  ``numpy.random.default_rng(seed).uniform(low, high, size=N)``;
* an :class:`IndexExpression`, a formula in ``i`` such as ``"1 + 0.01*i"``.

:func:`make_perturbation` validates everything it can without knowing N; per-bead lists are
checked against N in :meth:`Perturbation.bead_values`.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np
import sympy

from pulsemap.symbolic.errors import closest
from pulsemap.symbolic.expression import (SYMBOLS, ExpressionError, bound_size, check_parameter_name, formula,
                                          free_names, is_polynomial_in_state, parse_expression, symbol)
from pulsemap.symbolic.param_values import (DRAW_KEYS, IndexExpression, ParamMap, ParamValue, PerturbationError,
                                          RandomDraw, check_beads, check_name, evaluate_per_bead, exact, finite_float,
                                          frozen_values_per_bead, is_scalar, numeric_value, param_data,
                                          parse_cli_param, parse_param_value, to_float, value_kind, values_per_bead)

__all__ = [
    "DRAW_KEYS",
    "IndexExpression",
    "ParamMap",
    "ParamValue",
    "Perturbation",
    "PerturbationError",
    "RandomDraw",
    "check_all_used",
    "make_perturbation",
    "param_data",
    "parse_cli_param",
    "parse_param_value",
]


@dataclass(frozen=True)
class Perturbation:
    """eps * R_i(u, v) with its parameter values (paper Eq. 1)."""

    R: sympy.Expr
    text: str
    eps: float
    params: ParamMap

    @property
    def used_parameters(self) -> tuple[str, ...]:
        """Parameter names that occur in R, sorted."""
        names = {s.name for s in self.R.free_symbols} - set(SYMBOLS)
        return tuple(sorted(names))

    @property
    def is_zero(self) -> bool:
        """R = 0: the bare chain of Eq. 1 (no on-site force)."""
        return self.R == 0

    @property
    def acts(self) -> bool:
        """Whether the chain feels the on-site force: R is not zero and eps is not 0."""
        return not (self.is_zero or self.eps == 0)

    @property
    def is_polynomial(self) -> bool:
        """R is a polynomial in u, v (Eq. 10's monomials: what the map and the long-wave law integrate)."""
        return is_polynomial_in_state(self.R)

    @property
    def unused_parameters(self) -> tuple[str, ...]:
        """Parameters given a value but absent from R, sorted."""
        used = set(self.used_parameters)
        return tuple(name for name in self.params if name not in used)

    @property
    def free_parameters(self) -> tuple[str, ...]:
        """Parameters of R given no value: they stay sympy symbols (uniform along the chain), sorted."""
        return tuple(name for name in self.used_parameters if name not in self.params)

    @property
    def site_dependent(self) -> tuple[str, ...]:
        """Parameters of R whose values vary along the chain (lists, draws, expressions of i)."""
        return tuple(name for name in self.used_parameters
                     if name in self.params and not is_scalar(self.params[name]))

    @property
    def is_uniform(self) -> bool:
        """True if R is free of i and every parameter used in R is a scalar (or a free symbol)."""
        if symbol("i") in self.R.free_symbols:
            return False
        return not self.site_dependent

    def scalar_params(self) -> dict[sympy.Symbol, sympy.Rational]:
        """Exact values of the scalar parameters, for substitution; only for uniform R."""
        if not self.is_uniform:
            raise PerturbationError(
                f"R = {self.text} is not uniform along the chain ({self._why_not_uniform()}): "
                "use bead_values(name, beads) for per-bead values"
            )
        return self.scalar_values()

    def scalar_values(self) -> dict[sympy.Symbol, sympy.Rational]:
        """Exact values of the parameters that are scalars (per-bead ones left out), for substitution."""
        return {symbol(name): exact(value) for name, value in self.params.items() if is_scalar(value)}

    def bead_values(self, name: str, beads: int) -> np.ndarray:
        """Values of parameter ``name`` for beads 1..beads, shape (beads,), float64."""
        if name not in self.params:
            close = closest(name, self.params)
            hint = f" (did you mean '{close}'?)" if close else ""
            raise PerturbationError(f"no parameter named '{name}'{hint}; known: {', '.join(self.params) or 'none'}")
        return values_per_bead(name, self.params[name], check_beads(beads))

    def values_at(self, name: str, positions) -> np.ndarray:
        """Parameter ``name`` at continuous bead positions (for laws in the contact index): an
        expression of i evaluated there; per-bead values (lists, draws) piecewise constant, bead
        round(position) (clipped to the chain the list covers); a scalar everywhere."""
        pos = np.atleast_1d(np.asarray(positions, dtype=np.float64))
        value = self.params.get(name) if name in self.params else None
        if value is None:
            self.bead_values(name, 1)  # raises the one-line error naming the known parameters
        if isinstance(value, float):
            return np.full(pos.shape, value)
        if isinstance(value, IndexExpression):
            with np.errstate(all="ignore"):
                out = np.broadcast_to(numeric_value(value.expr, {symbol("i"): pos}, f"parameter '{name}'"), pos.shape)
            out = np.asarray(out, dtype=np.float64)
            if not np.all(np.isfinite(out)):
                raise PerturbationError(f"parameter '{name}' = {value.text!r} is not finite at bead position "
                                        f"{float(pos[~np.isfinite(out)][0]):g}")
            return out
        beads = len(value) if isinstance(value, tuple) else int(max(1, np.ceil(pos.max() + 0.5)))
        arr = frozen_values_per_bead(name, value, beads)
        if pos.size == 1 and math.isfinite(pos[0]):  # one position (a law's right-hand side, at every evaluation): no array arithmetic
            return np.array([arr[min(max(math.floor(float(pos[0]) + 0.5), 1), arr.size) - 1]]).reshape(pos.shape)
        k = np.clip(np.floor(pos + 0.5).astype(int), 1, arr.size)
        return arr[k - 1]

    def rest_force(self, beads: int) -> np.ndarray:
        """R_i(0, 0) for beads 1..beads, evaluated with the per-bead parameter values."""
        beads = check_beads(beads)
        at_rest = self.R.subs({symbol("u"): 0, symbol("v"): 0})
        env = {symbol(name): self.bead_values(name, beads) for name in self.used_parameters}
        return evaluate_per_bead(at_rest, env, beads, "R(0,0)")

    def check_at_rest(self, beads: int, tol: float = 1e-12) -> None:
        """Raise PerturbationError unless R_i(0, 0) = 0 for every bead (the chain starts at rest)."""
        force = self.rest_force(beads)
        bad = np.flatnonzero(np.abs(force) > tol)
        if bad.size:
            k = int(bad[0])
            raise PerturbationError(
                f"R(0,0) = {force[k]:.6g} is not zero at bead {k + 1}: a constant force would move "
                "the chain before the pulse arrives; subtract it from R"
            )

    def _why_not_uniform(self) -> str:
        if symbol("i") in self.R.free_symbols:
            return "R depends on i"
        for name in self.site_dependent:
            value = self.params[name]
            if not is_scalar(value):
                return f"parameter '{name}' is {value_kind(value)}"
        return "uniform"


def make_perturbation(
    R: str | sympy.Expr, eps: float, params: Mapping[str, object] | None = None, *, free: bool = False
) -> Perturbation:
    """Validate R (text or sympy), eps and the parameter values; return a Perturbation.

    ``free``: a name in R without a value is a free parameter (a sympy symbol in every derived
    equation) instead of an error; scene files and the command line keep the error (typos).
    """
    raw_params = dict(params or {})
    values: dict[str, ParamValue] = {}
    for name, raw in raw_params.items():
        check_name(name)
        values[name] = parse_param_value(name, raw)
    eps_value = _parse_eps(eps)
    if isinstance(R, str):
        try:
            expr = parse_expression(R, list(values) + (free_names(R, values) if free else []))
        except ExpressionError as exc:
            raise PerturbationError(str(exc)) from exc
        text = R.strip()
    elif isinstance(R, sympy.Basic):
        expr = _from_sympy(R, values.keys(), free)
        text = formula(expr)
    elif isinstance(R, numbers.Real) and not isinstance(R, bool):
        expr = exact(finite_float("R", R))
        text = str(expr)
    else:
        raise PerturbationError(f"R must be a string or a sympy expression, got {type(R).__name__}")
    perturbation = Perturbation(R=expr, text=text, eps=eps_value, params=ParamMap.of(values))
    _check_typos(perturbation)
    _check_rest_symbolic(perturbation)
    return perturbation


def check_all_used(perturbation: Perturbation) -> Perturbation:
    """Return ``perturbation`` if R uses every parameter given a value, else raise PerturbationError.

    Scene files and the command line call this: a value R never reads is almost always a typo or
    a forgotten term in R, and ignoring it would silently compute a different model. (The Python
    API itself allows extra values; see :attr:`Perturbation.unused_parameters`.)
    """
    unused = perturbation.unused_parameters
    if unused:
        names = ", ".join(f"'{name}'" for name in unused)
        what = "parameter" if len(unused) == 1 else "parameters"
        raise PerturbationError(
            f"{what} {names} given but not used in R = {perturbation.text}: remove it or use it in R"
        )
    return perturbation


def _parse_eps(eps: object) -> float:
    if isinstance(eps, str):
        try:
            expr = parse_expression(eps, symbols=())
        except ExpressionError as exc:
            raise PerturbationError(f"eps: {exc}") from exc
        if expr.free_symbols:
            raise PerturbationError(f"eps = {eps!r} must be a number, not an expression of u, v or i")
        return _check_eps_sign(finite_float("eps", to_float(expr, "eps")))
    return _check_eps_sign(finite_float("eps", eps))


def _check_eps_sign(eps: float) -> float:
    if eps < 0:
        raise PerturbationError(
            f"eps = {eps!r} must be >= 0: eps is the size of the perturbation eps*R; "
            "put the sign into R (e.g. R = \"mu*v\" rather than eps < 0)"
        )
    return eps


def _from_sympy(R: sympy.Basic, parameters: Any, free: bool = False) -> sympy.Expr:
    """Check a sympy R from Python and rebuild it with the parser's (real) symbols."""
    if not isinstance(R, sympy.Expr):
        raise PerturbationError(f"R must be a sympy expression, got {type(R).__name__}")
    try:
        bound_size(R, "R")
    except ExpressionError as exc:
        raise PerturbationError(str(exc)) from None
    for number in R.atoms(sympy.Number):
        _check_float64(number)
    known = set(SYMBOLS) | set(parameters)
    undefined = R.atoms(sympy.core.function.AppliedUndef)
    if undefined:
        raise PerturbationError(f"R contains undefined function {sorted(map(str, undefined))[0]}: use u, v, i and parameters")
    if R.has(sympy.Derivative, sympy.Integral):
        raise PerturbationError("R must not contain unevaluated derivatives or integrals")
    replacements = {}
    for sym in sorted(R.free_symbols, key=lambda s: s.name):
        if not isinstance(sym, sympy.Symbol):
            raise PerturbationError(f"R contains {sym!r}, which is not a plain symbol")
        if sym.name == "eps":
            raise PerturbationError("'eps' must not appear in R: eps is given separately and multiplies R")
        if sym.name not in known:
            if not free:
                raise PerturbationError(_unknown_symbol(sym.name, str(R), parameters))
            try:
                check_parameter_name(sym.name)
            except ExpressionError as exc:
                raise PerturbationError(f"R contains the symbol {sym.name!r}: {exc}") from None
        replacements[sym] = symbol(sym.name)
    expr = R.xreplace(replacements)
    if expr.has(sympy.zoo, sympy.oo, -sympy.oo, sympy.nan):
        raise PerturbationError(f"R = {expr} is not finite: check for division by zero or log(0)")
    if expr.has(sympy.I):
        raise PerturbationError(f"R = {expr} is complex: R must be real")
    return expr


def _check_float64(number: sympy.Number) -> None:
    """A number in a sympy R must be a float64 as the text's numbers are (tokens.number): not beyond
    about 1.8e308 and, unless 0, not rounded to 0."""
    if not number.is_finite:
        return  # oo, zoo, nan: refused as "not finite" below
    try:
        value = float(number)
    except OverflowError:
        value = math.inf
    shown = sympy.sstr(number.evalf(6)) if not number.is_Integer else f"{str(number)[:12]}... ({len(str(number))} digits)"
    if not math.isfinite(value):
        raise PerturbationError(f"R contains the number {shown}, beyond float64 (about 1.8e308): give a smaller "
                                "number, or make it a parameter")
    if value == 0.0 and number != 0:
        raise PerturbationError(f"R contains the number {shown}, which float64 rounds to 0.0: use 0 or a value above "
                                "1e-308")


def _unknown_symbol(name: str, text: str, parameters: Any) -> str:
    close = closest(name, sorted(parameters))
    hint = f"did you mean '{close}'? " if close else ""
    return (
        f"unknown symbol '{name}' in \"{text[:60]}\": {hint}declare it as a parameter "
        f"(--param {name}=VALUE) or use u, v, i"
    )


def _check_typos(perturbation: Perturbation) -> None:
    used = list(SYMBOLS) + list(perturbation.used_parameters)
    for name in perturbation.unused_parameters:
        close = closest(name, used, cutoff=0.8)
        if close:
            raise PerturbationError(
                f"parameter '{name}' is not used in R = {perturbation.text} but looks like a typo "
                f"of '{close}': rename or remove it"
            )


def _check_rest_symbolic(perturbation: Perturbation) -> None:
    """R_i(0, 0) must vanish for every bead: decide symbolically where possible."""
    at_rest = perturbation.R.subs({symbol("u"): 0, symbol("v"): 0})
    if at_rest.has(sympy.zoo, sympy.oo, -sympy.oo, sympy.nan):
        raise PerturbationError(
            f"R(0,0) is undefined for R = {perturbation.text} ({at_rest}): the chain starts at rest, "
            "so R must be finite and zero at u = v = 0"
        )
    scalars = perturbation.scalar_values()
    if perturbation.R.subs(scalars).has(sympy.zoo, sympy.oo, -sympy.oo, sympy.nan):
        raise PerturbationError(
            f"R = {perturbation.text} is undefined with the given parameter values "
            f"({', '.join(f'{k}={v}' for k, v in scalars.items())}): check for division by zero"
        )
    at_rest = at_rest.subs(scalars)
    bead_index = sympy.Symbol("i", positive=True, integer=True)
    at_rest = at_rest.xreplace({symbol("i"): bead_index})
    if at_rest == 0:
        return
    free = {symbol(name) for name in perturbation.free_parameters}
    if at_rest.free_symbols - {bead_index} - free:
        return  # depends on per-bead values: checked by Perturbation.check_at_rest(beads)
    if not at_rest.free_symbols:
        if abs(complex(sympy.N(at_rest, 30))) < 1e-20:
            return  # zero up to rounding, e.g. sin(1)**2 + cos(1)**2 - 1
    elif sympy.count_ops(at_rest) <= 200 and sympy.simplify(at_rest) == 0:
        return
    shown = str(at_rest.xreplace({bead_index: symbol("i")}))
    if len(shown) > 80:
        shown = shown[:77] + "..."
    if at_rest.is_number and not at_rest.is_Rational:
        shown = f"{shown} (= {float(sympy.N(at_rest)):.6g})"
    unset = sorted(s.name for s in at_rest.free_symbols if s.name in perturbation.free_parameters)
    hint = f" ({', '.join(unset)}: a parameter given no value; the state is u, v and the bead index i)" if unset else ""
    raise PerturbationError(
        f"R(0,0) = {shown} is not zero{hint}: a constant force would move the chain before the pulse "
        "arrives (it starts at rest in equilibrium); subtract it from R"
    )
