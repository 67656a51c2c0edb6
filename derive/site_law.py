"""Amplitude laws for a site-dependent R: coefficients C_p(i) that vary along the chain.

The long-wave law (Eq. 30) and the balance laws (derive/balance.py) for a uniform R are

    K dB/di = eps sum_p C_p B^p,   B = A^Q.

When R's parameters vary with the bead (an expression of i, per-bead values) or R contains i,
the same reduction holds with C_p(i), the coefficient of the bead (or pair of beads) the wave
meets at contact index i:

* balance laws: the step from contact i-1 to contact i is bead i's work (the balance map), so at
  the continuous contact index i the bead is at i + 1/2;
* long-wave law: the first map equation of contact i holds R_i and R_{i+1} (Eq. 12), so a
  parameter of bead i + m is taken at i + m.

One power p and a C_p(i) that sympy integrates (a polynomial in i always):
B^(1-p) = B_0^(1-p) + (1-p) eps/K int_{i0}^{i} C_p, or B = B_0 exp(eps/K int C_p) for p = 1.
Otherwise (several powers, per-bead lists or draws, no antiderivative) the law is the ODE,
integrated numerically (solvers/models/site_law_eval.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy
from sympy.core.function import AppliedUndef

from .errors import PulsemapError
from .expansion import bead_symbol
from .expression import symbol
from .longwave import needs_values
from .perturbation import IndexExpression, Perturbation
from .sympy_cache import bounded_cached

A0 = sympy.Symbol("A_0", positive=True)
I = symbol("i")  # noqa: E741  (the continuous contact index; the same symbol as R's i)
I0 = sympy.Symbol("i_0", real=True)
IVAR = sympy.Symbol("iota", real=True)  # integration variable
EPS = sympy.Symbol("epsilon", positive=True)

#: Where a parameter of bead i + offset sits along the contact index, per law.
BEAD_SHIFT = {"energy": sympy.Rational(1, 2), "momentum": sympy.Rational(1, 2), "longwave": sympy.Integer(0)}


class SiteLawError(PulsemapError):
    """A site-dependent law that cannot be formed (the message says why)."""


def coefficient_of_i(coefficient: sympy.Expr, pert: Perturbation, law: str) -> sympy.Expr:
    """A term's coefficient (bead-indexed parameters k_i, k_ip1, ..., scalars, i) as a function of
    the contact index i: expressions of i put in at their bead's position, scalars by value,
    per-bead lists and draws as the function k(position) (printed, evaluated numerically)."""
    shift = BEAD_SHIFT[law]
    sub: dict = {I: I + shift}
    scalars = pert.scalar_values()
    for name in pert.used_parameters:
        if name not in pert.params:
            continue  # a free parameter (no value): stays a symbol
        value = pert.params[name]
        if name not in pert.site_dependent:
            sub[symbol(name)] = scalars[symbol(name)]
            continue
        for off in (0, 1, 2):
            where = I + shift + off
            if isinstance(value, IndexExpression):
                sub[bead_symbol(name, off)] = value.expr.xreplace({I: where})
            else:
                sub[bead_symbol(name, off)] = sympy.Function(name)(where)
    return sympy.expand(coefficient.xreplace(sub))


@dataclass(frozen=True)
class SiteLaw:
    """K dB/di = eps sum_p C_p(i) B^p, B = A^Q, for a site-dependent R, and its solution."""

    model: str  # "energy", "momentum" or "longwave"
    Q: sympy.Rational
    scale_name: str  # "E_1", "p_1", "(f1 - f3)"
    scale: float
    eps: float
    powers: tuple[sympy.Rational, ...]
    coefficients: tuple[sympy.Expr, ...]  # C_p(i), numeric constants
    kind: str  # "power law", "exponential", "quadrature", "constant"
    law: sympy.Expr | None  # A(i) in A_0, i_0, i (closed form)
    why_quadrature: str = ""

    def ode(self, symbolic: bool = True) -> sympy.Eq:
        """K dB/di = eps sum_p C_p(i) B^p (numeric constants; K and eps symbolic unless ``symbolic`` is False)."""
        Bf = sympy.Function("B")(I)
        K = sympy.Symbol(self.scale_name, positive=True) if symbolic else sympy.Float(self.scale, 15)
        e = EPS if symbolic else sympy.Float(self.eps, 15)
        rhs = sum((c * Bf**p for c, p in zip(self.coefficients, self.powers)), sympy.Integer(0))
        return sympy.Eq(K * Bf.diff(I), e * rhs)

    def residual(self) -> sympy.Expr:
        """K dB/di - eps sum C_p(i) B^p with B = law^Q (0 when the closed form solves the ODE)."""
        if self.law is None:
            raise SiteLawError("no closed form to substitute")
        Bl = self.law**self.Q
        rhs = sum((c * Bl**p for c, p in zip(self.coefficients, self.powers)), sympy.Integer(0))
        return sympy.Float(self.scale, 17) * sympy.diff(Bl, I) - sympy.Float(self.eps, 17) * rhs

    def lines(self, heading: str) -> list[str]:
        out = [heading, f"  {self.ode()}", f"  {self.ode(symbolic=False)}"]
        if self.kind == "constant":
            out.append("Amplitude law: A constant (no term acts on the wave)")
        elif self.law is not None:
            out.append(f"Amplitude law ({self.kind}, coefficients varying along the chain, closed form):")
            out.append(f"  A(i) = {self.law}")
        else:
            out.append(f"Amplitude law: by numerical integration of the ODE ({self.why_quadrature})")
            missing = sorted({s.name for c in self.coefficients for s in sympy.sympify(c).free_symbols} - {I.name})
            if missing:  # a parameter given no value: the integration needs its number
                out.append("  " + needs_values("its numerical integration", missing))
        return out

    def data(self) -> dict:
        return {
            "kind": self.kind,
            "site_dependent": True,
            "ode": str(self.ode()),
            "ode_numeric": str(self.ode(symbolic=False)),
            "B": f"A**({self.Q})",
            "terms": [{"power_of_B": str(p), "coefficient_of_i": str(c)} for p, c in zip(self.powers, self.coefficients)],
            self.scale_name: self.scale,
            "eps": self.eps,
            "law": str(self.law) if self.law is not None else None,
            "quadrature_reason": self.why_quadrature or None,
        }

    def latex(self) -> list[str]:
        out = [sympy.latex(self.ode())]
        if self.law is not None:
            out.append(rf"A(i) = {sympy.latex(self.law)}")
        return out


def site_law(model: str, Q: sympy.Rational, scale_name: str, scale: float, eps: float,
             groups: dict, seconds: float = 2.0) -> SiteLaw:
    """Solve K dB/di = eps sum_p C_p(i) B^p; ``groups`` maps each power p of B to C_p(i) (numeric constants)."""
    powers = tuple(sorted(p for p, c in groups.items() if c != 0))
    coeffs = tuple(groups[p] for p in powers)
    if not powers:
        return SiteLaw(model, Q, scale_name, scale, eps, (), (), "constant", A0 + 0 * I)
    if len(powers) > 1:
        return SiteLaw(model, Q, scale_name, scale, eps, powers, coeffs, "quadrature", None,
                       "several powers of B with coefficients varying along the chain")
    (p,), (C,) = powers, coeffs
    if C.atoms(AppliedUndef):
        return SiteLaw(model, Q, scale_name, scale, eps, powers, coeffs, "quadrature", None,
                       "parameters given bead by bead: piecewise-constant coefficients")
    integrand = C.xreplace({I: IVAR})
    G = bounded_cached("integrate", f"{sympy.srepr(integrand)}|{sympy.srepr((IVAR, I0, I))}", sympy.integrate,
                       (integrand, (IVAR, I0, I)), seconds)
    if G is None or G.has(sympy.Integral):
        return SiteLaw(model, Q, scale_name, scale, eps, powers, coeffs, "quadrature", None,
                       "sympy found no antiderivative of the coefficient within the time bound")
    k = sympy.Float(eps / scale, 17)
    if p == 1:
        law = A0 * sympy.exp(k * G / Q)
        kind = "exponential"
    else:
        law = (A0 ** (Q * (1 - p)) + (1 - p) * k * G) ** (1 / (Q * (1 - p)))
        kind = "power law"
    return SiteLaw(model, Q, scale_name, scale, eps, powers, coeffs, kind, law)
