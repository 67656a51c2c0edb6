"""Expansion of the on-site perturbation into monomials of the travelling-wave ansatz (Eqs. 9-12, 23).

With u_i ~ delta_i + delta_{i+1} on (-inf, T_i] (Eq. 9) the forcing of contact i is

    g_i     = R_i(delta_i + delta_{i+1}, v_i + v_{i+1}) - R_{i+1}(delta_{i+1}, v_{i+1})   (Eq. 12)
    g_{i+1} = R_{i+1}(delta_{i+1}, v_{i+1}) - R_{i+2}(0, 0)                             (Eq. 21)

(v = delta'). A monomial delta_i^k delta_{i+1}^l v_i^m v_{i+1}^q of g_i integrates, with
delta_j = A S(A^s t - j), to A^(k + l + (1 + s)(m + q) - s) g^(1)_klmq; a monomial
delta_{i+1}^p v_{i+1}^r of g_{i+1} to A_{i+1}^(p + (1 + s) r - s) g^(2)_pr, s = (n - 1)/2.

Site-dependent parameters (per-bead values, or R depending on i) keep their bead: parameter
``k`` of bead i is the symbol ``k_i``, of bead i+1 ``k_ip1`` (printed k_{i+1}).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable

import sympy

from .errors import PulsemapError
from .expression import NON_SMOOTH, is_polynomial_in_state, symbol
from .integrals import g1_name, g2_name

#: The ansatz symbols: delta_i, delta_{i+1}, delta_i', delta_{i+1}'.
D0, D1, W0, W1 = sympy.symbols("delta_i delta_ip1 v_i v_ip1", real=True)


class ExpansionError(PulsemapError):
    """R cannot be expanded into the monomials of Eq. 23 (and why)."""


@dataclass(frozen=True)
class Term:
    """One monomial of the map: coefficient * A^power * integral (Eq. 23)."""

    equation: int  # 1: contact i (g^(1)); 2: auxiliary, contact i+1 (g^(2))
    exponents: tuple[int, ...]  # (k, l, m, q) or (p, r)
    coefficient: sympy.Expr  # in the parameters (bead-indexed when site-dependent)
    integral: str  # g1_klmq or g2_pr
    power: sympy.Rational  # of A_i (equation 1) or A_{i+1} (equation 2)

    @property
    def monomial(self) -> sympy.Expr:
        """The monomial of the ansatz symbols this term comes from."""
        if self.equation == 1:
            k, l, m, q = self.exponents
            return D0**k * D1**l * W0**m * W1**q
        p, r = self.exponents
        return D1**p * W1**r

    @property
    def monomial_text(self) -> str:
        """str(self.monomial), written directly (sympy's printer takes ms a term: seconds for thousands)."""
        names = ("delta_i", "delta_ip1", "v_i", "v_ip1") if self.equation == 1 else ("delta_ip1", "v_ip1")
        parts = [name if e == 1 else f"{name}**{e}" for name, e in zip(names, self.exponents) if e]
        return "*".join(parts) or "1"


@dataclass(frozen=True)
class Expansion:
    """g_i and g_{i+1} of Eq. 12/21 and their monomials."""

    R: sympy.Expr
    n: sympy.Rational
    g1: sympy.Expr  # g_i in D0, D1, W0, W1
    g2: sympy.Expr  # g_{i+1} in D1, W1
    terms: tuple[Term, ...]
    site_dependent: tuple[str, ...]  # parameters that carry a bead index

    @property
    def s(self) -> sympy.Rational:
        return (self.n - 1) / 2

    def integrals(self) -> tuple[str, ...]:
        """The integrals that occur (only these are ever computed)."""
        return tuple(dict.fromkeys(t.integral for t in self.terms))

    def equation_terms(self, equation: int) -> tuple[Term, ...]:
        return tuple(t for t in self.terms if t.equation == equation)


def exact_exponent(n: float | int | sympy.Rational | str) -> sympy.Rational:
    """n as an exact rational (1.5 -> 3/2), for exact powers of A."""
    if isinstance(n, sympy.Rational):
        return n
    value = sympy.Rational(str(n)) if not isinstance(n, int) else sympy.Integer(n)
    if value <= 1:
        raise ExpansionError(f"exponent n must be > 1, got {n}")
    return value


class BeadSymbol(sympy.Symbol):
    """A site-dependent parameter at one bead (k_i, k_ip1, k_ip2): its own class, so it never
    equals a user's parameter or an internal symbol of the same name."""


#: The printed suffix of a bead symbol, by offset from bead i (each ends differently, so that
#: name + suffix determines both the name and the offset).
BEAD_SUFFIX = {0: "_i", 1: "_ip1", 2: "_ip2"}


def bead_symbol(name: str, offset: int) -> sympy.Symbol:
    """Parameter ``name`` at bead i + offset (offset 0, 1, 2)."""
    return BeadSymbol(name + BEAD_SUFFIX[offset], real=True)


def _at_bead(R: sympy.Expr, offset: int, site_dependent: Iterable[str]) -> sympy.Expr:
    """R_{i+offset}: i -> i + offset and site-dependent parameters -> their bead symbols."""
    sub = {symbol(name): bead_symbol(name, offset) for name in site_dependent}
    if offset:
        sub[symbol("i")] = symbol("i") + offset
    return R.xreplace(sub) if sub else R


NOT_POLYNOMIAL_INSTEAD = ("pulsemap derive R --model energy tabulates its energy law by quadrature over the wave "
                          "and pulsemap run SCENE --methods energy-law,energy-map computes it")
"""What does take a non-polynomial R (solvers/models/energy_quadrature.py), named by every refusal of one."""


def check_polynomial_at_rest(R: sympy.Expr, needs: str, integrals: str,
                             error: type[ValueError] = ExpansionError) -> None:
    """R must be a polynomial in u, v (Eq. 10) that vanishes at rest; else ``error`` saying what
    ``needs`` the polynomial, what takes a non-polynomial R instead and which ``integrals`` a
    constant force makes diverge."""
    u, v = symbol("u"), symbol("v")
    if not is_polynomial_in_state(R):
        bad = [a for a in sympy.Add.make_args(sympy.expand(R)) if not is_polynomial_in_state(a)]
        kinks = sorted({str(f) for f in R.atoms(*NON_SMOOTH)})
        if kinks:
            raise error(
                f"R = {R} is not a polynomial in u, v ({kinks[0]} has a kink or a jump at 0): {needs}; "
                f"{NOT_POLYNOMIAL_INSTEAD}; the DNS runs it (methods = [\"dns\"])"
            )
        raise error(
            f"R = {R} is not a polynomial in u, v (term {bad[0] if bad else R}): {needs}; "
            f"{NOT_POLYNOMIAL_INSTEAD}; for a closed form, Taylor-expand it (e.g. sin(u) -> u - u**3/6)"
        )
    at_rest = sympy.simplify(R.xreplace({u: 0, v: 0}))
    if at_rest != 0:
        raise error(
            f"R(0, 0) = {at_rest} is not zero: a constant on-site force moves the chain before "
            f"the pulse arrives and makes {integrals} diverge; subtract it from R"
        )


MAX_MONOMIALS = 2000
"""Most monomials of Eq. 23 a map is derived with: (u+v+1)^12 - 1 has 1819; past that the
integrals, the law and the generated module take minutes (4844 of (u+v+1)^16: about a minute)."""


def check_size(R: sympy.Expr, error: type[ValueError] = ExpansionError) -> int:
    """The number of monomials of Eq. 23 for polynomial R (term c u^a v^b gives (a + 1)(b + 1) of
    g_i, by the binomial theorem); ``error`` past MAX_MONOMIALS, before any of them is written out."""
    monoms = sympy.Poly(R, symbol("u"), symbol("v")).monoms()
    count = len({(k, a - k, m, b - m) for a, b in monoms for k in range(a + 1) for m in range(b + 1)})
    if count > MAX_MONOMIALS:
        degree = max(a + b for a, b in monoms)
        raise error(
            f"R of degree {degree} in u, v expands into {count} monomials of Eq. 23, more than the "
            f"{MAX_MONOMIALS} a map is derived with (it would take many minutes): lower the degree of R, "
            "or run the DNS alone (methods = [\"dns\"])"
        )
    return count


def _state_terms(R: sympy.Expr, u: sympy.Symbol, v: sympy.Symbol) -> list[tuple[tuple[int, int], sympy.Expr]]:
    """((a, b), c) for the terms c u^a v^b of R (c free of u, v)."""
    return sympy.Poly(R, u, v).terms()


def _expanded(products) -> sympy.Expr:
    """The sum of ``products`` written out (as sympy.expand gives it), for display."""
    products = list(products)
    total = sympy.Add(*products)
    if all(p.as_coeff_Mul()[0].is_Number and not p.as_coeff_Mul()[1].has(sympy.Add) for p in products):
        return total  # numeric coefficients times monomials: already written out
    return sympy.expand(total)


def _tidy(coeff) -> sympy.Expr:
    """A monomial's coefficient in the parameters, expanded and with common factors pulled out."""
    coeff = sympy.sympify(coeff)
    return coeff if coeff.is_Number else sympy.factor_terms(sympy.expand(coeff))


def expand(
    R: sympy.Expr, n: float | sympy.Rational = 1.5, site_dependent: Iterable[str] = ()
) -> Expansion:
    """Expand R (polynomial in u, v) into the monomials of Eq. 23 for exponent n."""
    n_exact = exact_exponent(n)
    site = tuple(sorted(site_dependent))
    check_polynomial_at_rest(R, "the map of Eq. 23 needs polynomial R (Eq. 10)", "the integrals of Eq. 23")
    u, v = symbol("u"), symbol("v")
    r_i = _at_bead(R, 0, site)
    r_ip1 = _at_bead(R, 1, site)
    check_size(R)
    # g_i = R_i(delta_i + delta_ip1, v_i + v_ip1) - R_{i+1}(delta_ip1, v_ip1) term by term: c u^a v^b gives
    # c C(a, k) C(b, m) delta_i^k delta_ip1^(a-k) v_i^m v_ip1^(b-m) (binomial theorem; no sympy expand of
    # the substituted powers, which took minutes for (u+v+1)^16)
    g1_coeffs: dict[tuple[int, ...], sympy.Expr] = {}
    for (a, b), c in _state_terms(r_i, u, v):
        for k in range(a + 1):
            for m in range(b + 1):
                key = (k, a - k, m, b - m)
                g1_coeffs[key] = g1_coeffs.get(key, 0) + c * (math.comb(a, k) * math.comb(b, m))
    g2_coeffs: dict[tuple[int, ...], sympy.Expr] = {}
    for (a, b), c in _state_terms(r_ip1, u, v):
        g1_coeffs[(0, a, 0, b)] = g1_coeffs.get((0, a, 0, b), 0) - c
        g2_coeffs[(a, b)] = g2_coeffs.get((a, b), 0) + c
    s = (n_exact - 1) / 2
    terms: list[Term] = []
    for (k, l, m, q), coeff in g1_coeffs.items():
        coeff = _tidy(coeff)
        if coeff == 0:
            continue
        terms.append(Term(1, (k, l, m, q), coeff, g1_name(k, l, m, q), k + l + (1 + s) * (m + q) - s))
    for (p, r), coeff in g2_coeffs.items():
        coeff = _tidy(coeff)
        if coeff == 0:
            continue
        terms.append(Term(2, (p, r), coeff, g2_name(p, r), p + (1 + s) * r - s))
    g_i = _expanded(t.coefficient * t.monomial for t in terms if t.equation == 1)
    g_ip1 = _expanded(t.coefficient * t.monomial for t in terms if t.equation == 2)
    terms.sort(key=lambda t: (t.equation, t.power, t.exponents))
    return Expansion(R=R, n=n_exact, g1=g_i, g2=g_ip1, terms=tuple(terms), site_dependent=site)
