"""The second-order ("dressed") amplitude law: the energy law plus its next order.

Per monomial j of eps R = sum_j c_j u^a_j v^b_j, with x_j = c_j A^e_j, e_j = a_j + (1 + s) b_j - 1 - 2 s
(s = (n - 1)/2; n = 3/2: a + 5b/4 - 3/2):

    d ln A/di = - sum_j k1_j x_j lambda_j(x_j) - sum_{j<l} k2_jl x_j x_l,   lambda_j(x) = 1/(1 - rho_j x)

rho_j = k2_jj/k1_j (Pade [1/1] of 1 + rho x), k1_j = -w_ab/((n + 1) E_1) the energy balance (derived,
derive/balance.py). The onset: the law starts from ln A(i0) + sum_j Delta_j k1_j x_j(A_i0) lambda_j
(a lag of Delta_j contacts behind the seed). One monomial integrates in closed form
(z = A^e: (1 - rho c z) dz / z^2 = -e k1 c di):

    A^(-e) + rho c e ln A = A_s^(-e) + rho c e ln A_s + e k1 c (i - i0)     (e != 0)
    ln A = ln A_s - k1 c lambda (i - i0)                                      (e = 0)

Validity: the two-term law is trusted while |x| stays below the smaller of 1/|rho| (the second
term equals the first; the Pade pole) and the x where the next measured term of
delta/(k1 x) = 1 + rho x + ... equals rho x (|x| = (rho/g)^2 for a g |x|^(3/2) term, |rho/r1| for r1 x^2).

This module builds the law from coefficients it is given, each with how it was obtained
("derived (method, accuracy)" or "calibrated" and its accuracy): rho, Delta and k2_jl are derived by
expanding Eq. 1 to second order about the exact wave (solvers/models/dressed_expansion.py: a numeric
time integration, so it lives in solvers/), with DNS fits (solvers/studies/dressed_calibration.py,
``calibrate``) as the fallback; derive/ runs neither.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import sympy

from pulsemap.symbolic.errors import PulsemapError

A = sympy.Symbol("A", positive=True)
A_S = sympy.Symbol("A_s", positive=True)  # the amplitude the law starts from at i0 (seed shifted by the lag)
I = sympy.Symbol("i", real=True)  # noqa: E741
I0 = sympy.Symbol("i_0", real=True)


class DressedError(PulsemapError):
    """A dressed law that cannot be formed (the message says why)."""


@dataclass(frozen=True)
class DressedTerm:
    """One monomial c u^a v^b of eps R with its first- and second-order coefficients."""

    monomial: str
    exponents: tuple[int, int]
    c: float  # coefficient in eps R (eps included)
    e: sympy.Rational  # x = c A^e
    k1: float
    k1_method: str
    rho: float  # k2_jj / k1_j
    rho_error: float
    rho_method: str
    lag: float  # onset lag Delta_j, contacts
    lag_error: float
    lag_method: str
    next_kind: str  # "|x|^(3/2)" or "x^2": the next measured term of delta/(k1 x)
    next_coefficient: float
    c_of_i: sympy.Expr | None = None  # site-dependent R: c_j(i) in the contact index i (c: its value at i0)

    @property
    def k2(self) -> float:
        return self.rho * self.k1

    def x(self, amplitude: float) -> float:
        return self.c * amplitude ** float(self.e)

    def x_bound(self) -> tuple[float, str]:
        """The largest |x| where the two-term law is trusted, and which condition sets it."""
        out = [(1.0 / abs(self.rho), "second term equals the first (Pade pole)")] if self.rho else []
        if self.next_coefficient:
            if self.next_kind == "|x|^(3/2)":
                out.append(((self.rho / self.next_coefficient) ** 2, "next term g|x|^(3/2) equals rho x"))
            else:
                out.append((abs(self.rho / self.next_coefficient), "next term r1 x^2 equals rho x"))
        return min(out) if out else (math.inf, "no second-order term")

    def c_symbolic(self) -> sympy.Expr:
        """c_j as an expression: c_j(i) for a site-dependent R, else the number."""
        return self.c_of_i if self.c_of_i is not None else sympy.Float(self.c, 17)

    def amplitude_bound(self) -> float | None:
        """A where |x(A)| reaches x_bound (None when e = 0 or c = 0: x does not depend on A; or c depends on i)."""
        if self.e == 0 or self.c == 0 or self.c_of_i is not None:
            return None
        xb, _ = self.x_bound()
        if not math.isfinite(xb):
            return None
        return (xb / abs(self.c)) ** (1.0 / float(self.e))


@dataclass(frozen=True)
class CrossTerm:
    """k2_jl x_j x_l for a pair of monomials (None: not computed)."""

    first: str
    second: str
    k2: float | None
    error: float | None
    method: str


@dataclass(frozen=True)
class DressedLaw:
    """d ln A/di = -sum k1 x lambda(x) - sum k2_jl x_j x_l, with the onset shift and its solution."""

    n: float
    terms: tuple[DressedTerm, ...]
    cross: tuple[CrossTerm, ...] = ()
    notes: tuple[str, ...] = field(default_factory=tuple)

    # ------------------------------------------------------------------ the law
    def rate(self, amplitude=A) -> sympy.Expr:
        """d ln A/di as an expression of A (numeric constants)."""
        total = sympy.Integer(0)
        xs = {}
        for t in self.terms:
            x = t.c_symbolic() * amplitude**t.e
            xs[t.monomial] = x
            total += -sympy.Float(t.k1, 17) * x / (1 - sympy.Float(t.rho, 17) * x)
        for ct in self.cross:
            if ct.k2 is not None:
                total += -sympy.Float(ct.k2, 17) * xs[ct.first] * xs[ct.second]
        return total

    def rate_value(self, amplitude: float) -> float:
        """d ln A/di at amplitude A (float)."""
        total = 0.0
        xs = {}
        for t in self.terms:
            x = t.x(amplitude)
            xs[t.monomial] = x
            total -= t.k1 * x / (1.0 - t.rho * x)
        for ct in self.cross:
            if ct.k2 is not None:
                total -= ct.k2 * xs[ct.first] * xs[ct.second]
        return total

    def ode(self) -> sympy.Eq:
        Af = sympy.Function("A")(I)
        return sympy.Eq(sympy.Derivative(sympy.log(Af), I), self.rate(Af))

    def onset_shift(self, A0: float) -> float:
        """ln A_s - ln A0 = sum_j Delta_j k1_j x_j(A0) lambda_j(x_j(A0))."""
        return sum(t.lag * t.k1 * t.x(A0) / (1.0 - t.rho * t.x(A0)) for t in self.terms)

    def implicit(self) -> sympy.Expr | None:
        """i(A) from A(i0) = A_s for one monomial (module docstring); None for several or a site-dependent c(i)."""
        if len(self.terms) != 1 or self.terms[0].c_of_i is not None:
            return None
        (t,) = self.terms
        c, k1, rho, e = (sympy.Float(v, 17) for v in (t.c, t.k1, t.rho, float(t.e)))
        if t.c == 0 or t.k1 == 0:
            return None
        if t.e == 0:
            lam = 1 / (1 - rho * c)
            return I0 + (sympy.log(A_S) - sympy.log(A)) / (k1 * c * lam)
        ee = t.e
        return I0 + (A ** (-ee) - A_S ** (-ee) + rho * c * e * (sympy.log(A) - sympy.log(A_S))) / (e * k1 * c)

    def residual(self, amplitude: float) -> float:
        """(di/dA of the closed form) * A * (d ln A/di) - 1 at A (0 when the closed form solves the ODE)."""
        imp = self.implicit()
        if imp is None:
            raise DressedError("no closed form: the law has several monomials")
        didA = sympy.diff(imp, A)
        return float((didA * A * self.rate(A)).subs(A, amplitude)) - 1.0

    # ------------------------------------------------------------------ output
    def validity(self) -> list[dict]:
        out = []
        for t in self.terms:
            xb, why = t.x_bound()
            holds = (("A above A_bound" if float(t.e) < 0 else "A below A_bound") if t.e != 0 else
                     "every A (x does not depend on A)")
            if t.c_of_i is not None and t.e != 0:
                holds = "|c_j(i)| A^e_j below x_bound (the bound on A moves along the chain)"
            out.append({"monomial": t.monomial, "x_bound": xb if math.isfinite(xb) else None, "set_by": why,
                        "A_bound": t.amplitude_bound(), "holds_for": holds})
        return out

    def data(self, A0: float | None = None, i0: float = 0.0) -> dict:
        """The ``dressed`` JSON object."""
        imp = self.implicit()
        out = {
            "law": "d ln A/di = -sum_j k1_j x_j/(1 - (k2_jj/k1_j) x_j) - sum_{j<l} k2_jl x_j x_l, x_j = c_j A^e_j",
            "ode": str(self.ode()),
            "n": self.n,
            "monomials": {
                t.monomial: {
                    "exponents": list(t.exponents), "c": t.c, "e": str(t.e),
                    "c_of_i": None if t.c_of_i is None else str(t.c_of_i),
                    "k1": t.k1, "k1_method": t.k1_method,
                    "k2": t.k2, "k2_over_k1": t.rho, "k2_over_k1_error": t.rho_error, "k2_method": t.rho_method,
                    "onset_lag": t.lag, "onset_lag_error": t.lag_error, "onset_lag_method": t.lag_method,
                    "next_term": {"kind": t.next_kind, "coefficient": t.next_coefficient},
                } for t in self.terms
            },
            "cross": [{"monomials": [ct.first, ct.second], "k2": ct.k2, "error": ct.error, "method": ct.method}
                      for ct in self.cross],
            "closed_form_i_of_A": str(imp) if imp is not None else None,
            "validity": self.validity(),
            "notes": list(self.notes),
        }
        if A0 is not None:
            shift = self.onset_shift(A0)
            out["onset"] = {"A0": A0, "i0": i0, "ln_shift": shift, "A_s": A0 * math.exp(shift)}
        return out

    def lines(self, A0: float | None = None, i0: float = 0.0) -> list[str]:
        out = ["Dressed law (second order; per monomial x_j = c_j A^e_j, lambda_j = 1/(1 - (k2/k1)_j x_j)):",
               "  d ln A/di = -sum_j k1_j x_j lambda_j(x_j) - sum_{j<l} k2_jl x_j x_l",
               f"  {self.ode()}", ""]
        for t in self.terms:
            site = "" if t.c_of_i is None else f" at i0; c(i) = {t.c_of_i}"
            out.append(f"  {t.monomial}: c = {t.c:.10g}{site}, e = {t.e}")
            out.append(f"    k1 = {t.k1:.10g}  [{t.k1_method}]")
            out.append(f"    k2/k1 = {t.rho:.6g} +- {t.rho_error:.2g}  [{t.rho_method}]")
            out.append(f"    onset lag = {t.lag:.5g} +- {t.lag_error:.2g} contacts  [{t.lag_method}]")
            out.append(f"    next term of delta/(k1 x): {t.next_coefficient:.4g} {t.next_kind}  [calibrated, rough]")
        for ct in self.cross:
            val = f"{ct.k2:.5g} +- {ct.error:.2g}" if ct.k2 is not None else "not computed"
            out.append(f"  cross {ct.first} x {ct.second}: k2 = {val}  [{ct.method}]")
        imp = self.implicit()
        out.append("")
        if not self.terms:
            out.append("Amplitude law: A constant (no term of R does work on the wave)")
        elif any(t.c_of_i is not None for t in self.terms):
            out.append("Amplitude law: by numerical integration of the ODE (c_j depends on i: run follows c_j(i))")
        elif imp is not None:
            out.append("Closed form (one monomial; A_s = the seed amplitude shifted by the onset lag):")
            out.append(f"  i(A) = {imp}")
        else:
            out.append("Amplitude law: by numerical integration of the ODE (several monomials)")
        if A0 is not None:
            shift = self.onset_shift(A0)
            out.append(f"  onset: ln A_s = ln A0 + {shift:.6g} (A0 = {A0:g} at i0 = {i0:g}: A_s = {A0 * math.exp(shift):.8g})")
        out.append("Validity (two-term law):")
        for v in self.validity():
            xb = "none" if v["x_bound"] is None else f"|x| < {v['x_bound']:.4g}"
            ab = "" if v["A_bound"] is None else f", i.e. {v['holds_for']} = {v['A_bound']:.4g}"
            where = f" ({v['holds_for']})" if "moves" in v["holds_for"] else ""
            out.append(f"  {v['monomial']}: {xb} ({v['set_by']}){ab}{where}")
        out += [f"Note: {n}" for n in self.notes]
        return out

    def latex(self) -> str:
        return sympy.latex(self.ode())
