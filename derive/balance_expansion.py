"""R split into the monomials c u^a v^b whose work (energy balance) or impulse (momentum balance) on
a passing wave of scale A is c A^power times a profile integral (derive/balance.py)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

import sympy

from .balance_constants import WAVE_NAMES, BalanceError, check_model, integral_name
from .expansion import bead_symbol, check_polynomial_at_rest, exact_exponent
from .expression import symbol

__all__ = ["A", "BalanceExpansion", "BalanceTerm", "balance_expand"]

A = sympy.Symbol("A", positive=True)


@dataclass(frozen=True)
class BalanceTerm:
    """One monomial c u^a v^b of R: its work (energy) or impulse (momentum) is c A^power integral."""

    exponents: tuple[int, int]  # (a, b)
    coefficient: sympy.Expr  # in the parameters (bead-indexed name_i when site-dependent) and i
    integral: str  # w_ab or j_ab
    power: sympy.Rational  # of A

    @property
    def monomial(self) -> sympy.Expr:
        a, b = self.exponents
        return symbol("u") ** a * symbol("v") ** b


@dataclass(frozen=True)
class BalanceExpansion:
    """R split into monomials, with the power of A and the profile integral of each (model-specific)."""

    model: str
    R: sympy.Expr
    n: sympy.Rational
    terms: tuple[BalanceTerm, ...]
    site_dependent: tuple[str, ...]

    @property
    def s(self) -> sympy.Rational:
        return (self.n - 1) / 2

    @property
    def Q(self) -> sympy.Rational:
        """The wave's balanced quantity scales as A^Q: n + 1 (energy), 1 + s (momentum)."""
        return self.n + 1 if self.model == "energy" else 1 + self.s

    @property
    def wave_names(self) -> tuple[str, ...]:
        return WAVE_NAMES[self.model]

    def integrals(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(t.integral for t in self.terms))

    @property
    def uniform(self) -> bool:
        return not self.site_dependent and symbol("i") not in self.R.free_symbols

    def rate(self, amplitude: sympy.Expr = A, constants: dict | None = None) -> sympy.Expr:
        """sum c A^power integral (W/eps or J/eps); integrals as symbols unless ``constants`` given."""
        total = sympy.Integer(0)
        for t in self.terms:
            value = sympy.Symbol(t.integral, real=True) if constants is None else sympy.Float(constants[t.integral], 17)
            total += t.coefficient * value * amplitude**t.power
        return total


MAX_BALANCE_TERMS = 120
"""Most terms c u^a v^b of R a balance is derived with ((u+v+1)^14 - 1 has 119): each needs a
profile quadrature of 0.3-1 s, so more would take minutes."""


def balance_expand(R: sympy.Expr, n: float | sympy.Rational = 1.5, model: str = "energy", site_dependent: Iterable[str] = ()) -> BalanceExpansion:
    """Expand R = sum c_ab u^a v^b into the work (energy) or impulse (momentum) terms of the model."""
    check_model(model)
    n_exact = exact_exponent(n)
    site = tuple(sorted(site_dependent))
    check_polynomial_at_rest(R, f"the {model} balance integrates R term by term", f"the {model} balance's integrals",
                             BalanceError)
    u, v = symbol("u"), symbol("v")
    R_i = R.xreplace({symbol(name): bead_symbol(name, 0) for name in site}) if site else R
    s = (n_exact - 1) / 2
    terms: list[BalanceTerm] = []
    no_v: list[sympy.Expr] = []
    for (a, b), coeff in sympy.Poly(sympy.expand(R_i), u, v).terms():
        coeff = sympy.factor_terms(coeff)
        if coeff == 0:
            continue
        if model == "momentum" and b == 0:
            no_v.append(coeff * u**a)
            continue
        power = a + (1 + s) * (b + 1) - s if model == "energy" else a + (1 + s) * b - s
        terms.append(BalanceTerm((a, b), coeff, integral_name(model, a, b), power))
    if no_v:
        shown = ", ".join(str(t) for t in reversed(no_v))
        raise BalanceError(
            f"the momentum balance is undefined for R = {R}: its term(s) without v ({shown}) keep acting "
            "on the bead the wave leaves displaced (x -> A*D), so the impulse int R dt diverges; "
            "the energy balance (--model energy, run --methods energy-law) or the map (--model map) takes it"
        )
    if len(terms) > MAX_BALANCE_TERMS:
        raise BalanceError(
            f"R of degree {max(a + b for a, b in (t.exponents for t in terms))} in u, v has {len(terms)} terms, "
            f"more than the {MAX_BALANCE_TERMS} the {model} balance is derived with (one quadrature of up to "
            "a second each): lower the degree of R, or run the DNS alone (methods = [\"dns\"])"
        )
    terms.sort(key=lambda t: (t.power, t.exponents))
    return BalanceExpansion(model, R, n_exact, tuple(terms), site)
