"""The balance laws K dB/di = eps sum_p C_p B^p, B = A^Q (K = E_1 or p_1), uniform or site-dependent,
and their solutions A(i) (derive/balance.py)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import mpmath
import sympy

from .balance_constants import BalanceError
from .balance_expansion import A, BalanceExpansion
from .longwave import LAW_RATE, A0, I, I0, check_values, missing_values, numeric_coefficients, numeric_rate, reciprocal_integral
from .perturbation import Perturbation
from .site_law import SiteLaw, coefficient_of_i, site_law

__all__ = ["B", "EPS", "K_SYMBOLS", "BalanceLaw", "balance_law", "balance_site_law", "expansion_groups", "law_from_groups"]

B = sympy.Symbol("B", positive=True)
B0 = sympy.Symbol("B_0", positive=True)
K_RATE = LAW_RATE  # lambda_L = eps C / K, defined where a law prints it (longwave.law_lines)
EPS = sympy.Symbol("epsilon", positive=True)
#: The wave's energy and momentum coefficients as printed symbols.
K_SYMBOLS = {"energy": sympy.Symbol("E_1", positive=True), "momentum": sympy.Symbol("p_1", positive=True)}


@dataclass(frozen=True)
class BalanceLaw:
    """K dB/di = eps sum_p C_p B^p, B = A^Q (K = E_1 or p_1), and its solution A(i)."""

    model: str
    Q: sympy.Rational
    powers: tuple[sympy.Rational, ...]
    coefficients: tuple[float, ...]
    symbolic_coefficients: tuple[sympy.Expr, ...]
    K: float
    eps: float
    kind: str  # "power law", "exponential", "implicit", "quadrature", "constant"
    law: sympy.Expr | None  # A(i) in A_0, i, i_0 and k = eps C / K (one power)
    implicit: sympy.Expr | None  # i(A), numeric constants (several powers, closed form found)
    numeric_coefficients: tuple[sympy.Expr, ...] = ()  # C_p with numbers for all but the free parameters
    eps_symbol: sympy.Expr = EPS  # the printed factor of the right-hand side (1 when eps sits in the C_p)

    def ode(self, symbolic: bool = True) -> sympy.Eq:
        """K dB/di = eps sum C_p B^p with B = A^Q."""
        Bf = sympy.Function("B")(I)
        cs = self.symbolic_coefficients if symbolic else numeric_coefficients(self)
        K = K_SYMBOLS[self.model] if symbolic else sympy.Float(self.K, 15)
        e = self.eps_symbol if symbolic else sympy.Float(self.eps, 15)
        return sympy.Eq(K * Bf.diff(I), e * sum((c * Bf**p for c, p in zip(cs, self.powers)), sympy.Integer(0)))

    def rate(self) -> float:
        """k = eps C / K for a single power (0 when R does no work / gives no impulse)."""
        if not self.coefficients:
            return 0.0
        check_values(self, "the rate lambda_L", BalanceError)
        return self.eps * self.coefficients[0] / self.K

    def numeric_law(self) -> sympy.Expr | None:
        """The closed-form A(i) with all constants numeric (A_0, i_0 and free parameters symbolic)."""
        if self.law is None:
            return None
        if not missing_values(self):
            return self.law.xreplace({K_RATE: sympy.Float(self.rate(), 17)})
        return self.law.xreplace({K_RATE: numeric_rate(self, self.K)})

    def _rhs(self, b: float):
        """sum C_p B^p in mpmath (no overflow or underflow of B^p)."""
        return sum(c * mpmath.mpf(b) ** float(p) for c, p in zip(self.coefficients, self.powers))

    def singular_index(self, a0: float, i0: float = 0.0) -> tuple[float | None, str]:
        """(index, what) where A(i) reaches 0 ("extinction") or infinity ("blow-up"), else None and why."""
        if self.kind == "constant":
            return None, "no work on the wave: A stays constant"
        check_values(self, "the singular index of the law", BalanceError)
        if not a0 > 0:
            raise BalanceError(f"the initial amplitude A0 must be > 0, got {a0}")
        if len(self.powers) == 1:
            p, k = float(self.powers[0]), self.rate()
            if k == 0 or p == 1.0:
                return None, "exponential law: no finite-index singularity" if k else "zero coefficient: A constant"
            index = float(i0 - mpmath.mpf(a0) ** (float(self.Q) * (1 - p)) / ((1 - p) * k))
            if not math.isfinite(index):
                return None, "never singular at a finite index"
            if index <= i0:
                return None, ("decays" if k < 0 else "grows") + " algebraically, never singular"
            return index, "extinction (A -> 0)" if p < 1 else "blow-up (A -> inf)"
        b0 = a0 ** float(self.Q)
        f0 = self._rhs(b0)
        if f0 == 0:
            return None, "A0 is a stationary amplitude"
        ahead = [b0 * 10 ** (j / 50) for j in range(1, 801)]
        ahead = [b0 * 10 ** (-j / 50) for j in range(1, 801)] if f0 < 0 else ahead
        if any((self._rhs(b) > 0) != (f0 > 0) for b in ahead):
            return None, "approaches a stationary amplitude asymptotically"
        with mpmath.workdps(20):
            try:
                span = mpmath.quad(lambda b: 1 / self._rhs(b), [0, b0] if f0 < 0 else [b0, mpmath.inf])
            except (ZeroDivisionError, ValueError):
                return None, "quadrature failed"
        span = abs(float(span)) * self.K / self.eps
        if not math.isfinite(span) or span > 1e12:
            return None, "never singular at a finite index"
        return i0 + span, "extinction (A -> 0)" if f0 < 0 else "blow-up (A -> inf)"


def balance_law(ex: BalanceExpansion, constants: dict, params: dict, eps: float, seconds: float = 2.0) -> BalanceLaw:
    """Group the terms by power of B = A^Q and solve K dB/di = eps sum C_p B^p (closed form for one power)."""
    if not ex.uniform:
        raise BalanceError(
            f"the {ex.model}-balance law needs a uniform perturbation; this R is site-dependent "
            "(per-bead parameters or i): iterate the balance map instead"
        )
    K = constants["K1"] + constants["V1"] if ex.model == "energy" else constants["p1"]
    return law_from_groups(ex.model, ex.Q, expansion_groups(ex), constants, params, K, eps, seconds)


def expansion_groups(ex: BalanceExpansion, factor: sympy.Expr = sympy.Integer(1)) -> dict[sympy.Rational, sympy.Expr]:
    """The expansion's terms grouped by power of A: {p: factor sum C_t I_t} (I_t the integrals' symbols)."""
    groups: dict[sympy.Rational, sympy.Expr] = {}
    for t in ex.terms:
        groups[t.power] = groups.get(t.power, sympy.Integer(0)) + factor * t.coefficient * sympy.Symbol(t.integral,
                                                                                                        real=True)
    return groups


def law_from_groups(model: str, Q: sympy.Rational, groups: dict, constants: dict, params: dict, K: float, eps: float,
                    seconds: float = 2.0, eps_symbol: sympy.Expr = EPS) -> BalanceLaw:
    """Solve K dB/di = eps sum_p C_p B^p, B = A^Q, from ``groups`` {power of A: C in the integrals' symbols and the
    parameters} (closed form for one power); ``constants`` gives the integrals' values, ``params`` the parameters'."""
    powers, coeffs, symb, nums = [], [], [], []
    for power in sorted(groups):
        sym = sympy.expand(groups[power])
        num = sym.xreplace(params).xreplace({sympy.Symbol(k, real=True): sympy.Float(v, 17) for k, v in constants.items()})
        value = float(num) if not num.free_symbols else None
        if value == 0.0:
            continue
        powers.append(power / Q)
        coeffs.append(value)
        symb.append(sym)
        nums.append(sympy.expand(num))
    powers, coeffs, symb, num = tuple(powers), tuple(coeffs), tuple(symb), tuple(nums)
    extra = dict(eps_symbol=eps_symbol)
    if not powers:
        return BalanceLaw(model, Q, (), (), (), K, eps, "constant", A0 + 0 * I, None, **extra)
    if len(powers) == 1:
        (p,) = powers
        if p == 1:
            law_B = B0 * sympy.exp(K_RATE * (I - I0))
            kind = "exponential"
        else:
            law_B = (B0 ** (1 - p) + (1 - p) * K_RATE * (I - I0)) ** (1 / (1 - p))
            kind = "power law"
        law_A = sympy.powsimp(sympy.powdenest(law_B.xreplace({B0: A0**Q}) ** (1 / Q), force=True), force=True)
        return BalanceLaw(model, Q, powers, coeffs, symb, K, eps, kind, law_A, None, num, **extra)
    if any(c is None for c in coeffs):
        return BalanceLaw(model, Q, powers, coeffs, symb, K, eps, "quadrature", None, None, num, **extra)
    G = reciprocal_integral(coeffs, powers, seconds)
    if G is not None and not G.has(sympy.Integral):
        implicit = sympy.Float(K / eps, 17) * (G.xreplace({B: A**Q}) - G.xreplace({B: A0**Q})) + I0
        return BalanceLaw(model, Q, powers, coeffs, symb, K, eps, "implicit", None, implicit, num, **extra)
    return BalanceLaw(model, Q, powers, coeffs, symb, K, eps, "quadrature", None, None, num, **extra)


def balance_site_law(ex: BalanceExpansion, pert: Perturbation, constants: dict, seconds: float = 2.0) -> SiteLaw:
    """The balance law for a site-dependent R: K dB/di = eps sum_p C_p(i) B^p, bead i + 1/2 at index i
    (derive/site_law.py)."""
    K = constants["K1"] + constants["V1"] if ex.model == "energy" else constants["p1"]
    groups: dict = {}
    for t in ex.terms:
        c = coefficient_of_i(t.coefficient, pert, ex.model) * sympy.Float(constants[t.integral], 17)
        groups[t.power / ex.Q] = groups.get(t.power / ex.Q, sympy.Integer(0)) + c
    name = "E_1" if ex.model == "energy" else "p_1"
    return site_law(ex.model, ex.Q, name, K, float(pert.eps), {p: sympy.expand(c) for p, c in groups.items()}, seconds)
