"""The contact-law perturbation eps_c P_k(d, w) and the bead masses m_i: specs parsed from text like R.

    m_i x_i'' = F(d_(i-1), w_(i-1)) - F(d_i, w_i) + eps R_i(x_i, x_i'),
    F(d, w) = H(d) (d^n + eps_c P_k(d, w)),  d_k = x_k - x_(k+1),  w_k = d_k'

``P`` is a sum of monomials c d^a w^b (a >= 0 rational, b >= 0 integer; c may hold parameters and
the contact index k); it acts on contacts k >= first_perturbed. The masses are 1 before bead
first_perturbed and m_i from there: a number, a formula in i and parameters, a list or a random
draw. Per-contact and per-bead values take the forms of R's parameters (param_values.py).
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np
import sympy

from pulsemap.symbolic.contact import ContactError, ContactMonomial, contact_monomials
from pulsemap.symbolic.expression import CONTACT_SYMBOLS, ExpressionError, free_names, parse_expression, symbol
from pulsemap.symbolic.param_forms import param_data
from pulsemap.symbolic.param_values import (IndexExpression, ParamMap, PerturbationError, RandomDraw, check_name,
                                          evaluate_per_bead, finite_float, is_scalar, parse_param_value,
                                          values_per_bead)


class ContactLawError(PerturbationError):
    """A contact-law term P or the masses were rejected; the message says why and what to write."""


@dataclass(frozen=True)
class ContactLaw:
    """eps_c P_k(d, w) of F(d, w) = H(d) (d^n + eps_c P_k(d, w)) on contacts k >= first_perturbed."""

    P: sympy.Expr
    text: str
    eps: float
    params: ParamMap
    first_perturbed: int
    monomials: tuple[ContactMonomial, ...]

    @property
    def used_parameters(self) -> tuple[str, ...]:
        """Parameter names that occur in P, sorted."""
        return tuple(sorted({s.name for s in self.P.free_symbols} - set(CONTACT_SYMBOLS)))

    def contact_values(self, name: str, contacts: int) -> np.ndarray:
        """Parameter ``name`` on contacts 1..contacts (per-contact lists: contact k is element k-1)."""
        return values_per_bead(name, self.params[name], contacts)

    def table(self, contacts: int) -> tuple[np.ndarray, np.ndarray]:
        """The DNS's data: exponents (M, 2) [a_m, b_m] and coefficients (M, contacts) with eps folded in,
        zero on contacts before first_perturbed (column k-1 is contact k)."""
        k = np.arange(1, contacts + 1, dtype=np.float64)
        env = {symbol(name): self.contact_values(name, contacts) for name in self.used_parameters}
        env[symbol("k")] = k
        exps = np.array([[float(m.a), float(m.b)] for m in self.monomials], dtype=np.float64).reshape(-1, 2)
        coef = np.zeros((len(self.monomials), contacts))
        on = k >= self.first_perturbed
        for row, m in enumerate(self.monomials):
            what = f"the coefficient {m.coef} of d^{m.a} w^{m.b} in P"
            values = evaluate_per_bead(m.coef.xreplace({symbol("k"): symbol("i")}), env | {symbol("i"): k},
                                       contacts, what)
            coef[row] = np.where(on, self.eps * values, 0.0)
        return exps, coef


@dataclass(frozen=True)
class Masses:
    """Bead masses: 1 before bead first_perturbed, then ``m`` (a number, a tuple for beads
    first_perturbed.., a RandomDraw over beads 1..N, or an expression of i and ``params``)."""

    m: Any
    text: str
    params: ParamMap
    first_perturbed: int

    def data(self) -> object:
        """m in a scene file's form: a number, a list, a draw's table or the formula's text."""
        return self.text if isinstance(self.m, sympy.Expr) else param_data(self.m)

    def bead_masses(self, beads: int) -> np.ndarray:
        """m_i for beads 1..beads, shape (beads,); a list shorter than the chain keeps its last value."""
        out = np.ones(beads)
        start = self.first_perturbed - 1
        if start >= beads:
            return out
        if isinstance(self.m, tuple):
            values = np.asarray(self.m, dtype=np.float64)
            take = min(values.size, beads - start)
            out[start:start + take] = values[:take]
            out[start + take:] = values[-1]
        elif isinstance(self.m, sympy.Expr):
            env = {symbol(name): values_per_bead(name, self.params[name], beads) for name in self.params}
            out[start:] = evaluate_per_bead(self.m, env, beads, f"the mass m = {self.text}")[start:]
        else:
            out[start:] = values_per_bead("m", self.m, beads)[start:]
        bad = np.flatnonzero(~(np.isfinite(out) & (out > 0.0)))
        if bad.size:
            j = int(bad[0])
            raise ContactLawError(f"the mass of bead {j + 1} is {out[j]:.6g}: masses must be finite and > 0 "
                                  f"(check m = {self.text} and its parameters)")
        return out

    def check_list(self, beads_needed: int) -> None:
        """A list must cover beads first_perturbed..beads_needed (the last reported contact's far bead)."""
        if isinstance(self.m, tuple):
            need = beads_needed - self.first_perturbed + 1
            if len(self.m) < need:
                raise ContactLawError(
                    f"[masses] m lists {len(self.m)} masses but beads {self.first_perturbed}..{beads_needed} need "
                    f"{need}: give one mass per bead from first_perturbed to the last reported contact's far bead")


def _params(params: Mapping[str, object] | None, where: str) -> ParamMap:
    values = {}
    for name, raw in dict(params or {}).items():
        check_name(name)
        if name in CONTACT_SYMBOLS:
            raise ContactLawError(f"{where} parameter '{name}': d, w, k are the overlap, its rate and the "
                                  "contact index; choose another name")
        values[name] = parse_param_value(name, raw)
    return ParamMap.of(values)


def _first(first_perturbed: object, what: str) -> int:
    if isinstance(first_perturbed, bool) or not isinstance(first_perturbed, numbers.Integral) or first_perturbed < 1:
        raise ContactLawError(f"{what} first_perturbed must be an integer >= 1, got {first_perturbed!r}")
    return int(first_perturbed)


def make_contact_law(P: str | sympy.Expr, eps: object, params: Mapping[str, object] | None = None,
                     first_perturbed: object = 16, *, free: bool = False) -> ContactLaw:
    """Validate P (text in d, w, k and parameters, or sympy), eps and the parameter values; ``free``: a name
    in P without a value stays a symbol (the derivation's door) instead of an error (a scene's)."""
    values = _params(params, "[contact]")
    if isinstance(eps, bool) or not isinstance(eps, numbers.Real):
        raise ContactLawError(f"[contact] eps must be a number, got {eps!r}")
    eps_value = finite_float("[contact] eps", eps)
    if eps_value < 0:
        raise ContactLawError(f"[contact] eps = {eps_value!r} must be >= 0: put the sign into P")
    if isinstance(P, sympy.Basic):
        P = str(P)
    if not isinstance(P, str):
        raise ContactLawError(f"[contact] P must be a formula in d, w, k, got {type(P).__name__}")
    names = list(values) + (free_names(P, [*values, *CONTACT_SYMBOLS]) if free else [])
    try:
        expr = parse_expression(P, names, symbols=CONTACT_SYMBOLS)
    except ExpressionError as exc:
        raise ContactLawError(f"[contact] P: {exc}") from None
    unused = sorted(set(values) - {s.name for s in expr.free_symbols})
    if unused:
        raise ContactLawError(f"[contact] parameter '{unused[0]}' is given but not used in P = {P.strip()}: "
                              "remove it or use it in P")
    text = P.strip()
    try:
        monomials = contact_monomials(expr)
    except ContactError as exc:
        raise ContactLawError(f"[contact] P = {text}: {exc}") from None
    return ContactLaw(expr, text, eps_value, values, _first(first_perturbed, "[contact]"), monomials)


def make_masses(m: object, params: Mapping[str, object] | None = None, first_perturbed: object = 16) -> Masses:
    """Validate the masses: a number, a formula in i and parameters, a list or a random draw."""
    values = _params(params, "[masses]")
    first = _first(first_perturbed, "[masses]")
    if isinstance(m, str):
        try:
            expr = parse_expression(m, list(values), symbols=("i",))
        except ExpressionError as exc:
            raise ContactLawError(f"[masses] m: {exc}") from None
        unused = sorted(set(values) - {s.name for s in expr.free_symbols})
        if unused:
            raise ContactLawError(f"[masses] parameter '{unused[0]}' is given but not used in m = {m.strip()}")
        if not expr.free_symbols:
            m = float(expr)
        else:
            return Masses(expr, m.strip(), values, first)
    if isinstance(m, (bool, np.bool_)):
        raise ContactLawError(f"[masses] m = {m} is a boolean: give a number, a formula in i, a list or a draw")
    if values:
        raise ContactLawError(f"[masses] params are given but m = {m!r} is not a formula that uses them")
    try:
        value = parse_param_value("m", m)
    except PerturbationError as exc:
        raise ContactLawError(f"[masses] {exc}") from None
    if isinstance(value, IndexExpression):
        return Masses(value.expr, value.text, values, first)
    low = {float: lambda x: x, tuple: min, RandomDraw: lambda r: r.low}[type(value)](value)
    if not low > 0.0:
        raise ContactLawError(f"[masses] m must be > 0 on every bead, got {low!r}: masses are positive")
    text = str(value) if is_scalar(value) else ("a list" if isinstance(value, tuple) else "a random draw")
    return Masses(value, text, values, first)
