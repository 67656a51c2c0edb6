"""The long-wave limit of the map (Eqs. 27-31) and its amplitude law A(i).

For a uniform perturbation, with B = A^P, P = (n + 1)/2, and B_{i+-1} = B +- B' (Eq. 28) in the
first map equation (the contact terms cancel since f1 - 2 f2 + f3 = 0):

    (f1 - f3) dB/di = eps sum_p C_p B^p,   C_p = sum_j c_j g^(1)_j over terms of A-power P p  (Eq. 30)

One power: separation of variables gives a power law (or an exponential for p = 1) in closed
form. Several powers: i - i0 = (f1 - f3)/eps int_{B0}^{B} dB / sum_p C_p B^p (Eq. 31a), in
closed form when sympy integrates it within a time bound, else by quadrature. Every law is
derived here, never copied from the paper (errata 1-3, docs/errata.rst).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mpmath
import sympy

from .errors import PulsemapError
from .amplitude_map import EPS, F_SYMBOLS, AmplitudeMap, integral_symbol
from .expression import UserSymbol, symbol
from .sympy_cache import bounded_cached

B = sympy.Symbol("B", positive=True)
A = sympy.Symbol("A", positive=True)
A0 = sympy.Symbol("A_0", positive=True)
B0 = sympy.Symbol("B_0", positive=True)
I = sympy.Symbol("i", real=True)  # the continuous contact index ("t" in Eqs. 31, 36)
I0 = sympy.Symbol("i_0", real=True)
#: The rate of a one-power law, lambda_L = eps C / (f1 - f3) (or eps C / K for a balance law). A plain
#: sympy Symbol: never equal to a user's parameter (expression.UserSymbol), whatever its name.
LAW_RATE = sympy.Symbol("lambda_L", real=True)


class LongwaveError(PulsemapError):
    """The long-wave law cannot be formed (site-dependent R, no perturbation)."""


#: Initial amplitudes a law accepts: B = A0^P and the law's terms between A0/1e16 and 1e16 A0 stay
#: within float range for every supported n (P <= 10.5).
A0_RANGE = (1e-12, 1e12)
#: Largest |i0| (a contact index).
I0_LIMIT = 1e12
#: Largest time bound for sympy's closed-form integration, in seconds.
SYMPY_SECONDS_MAX = 3600.0


def _real(what: str, value: object, error: type[ValueError], valid: str) -> float:
    if isinstance(value, (bool, str)):
        raise error(f"{what} must be a number ({valid}), got {value!r}")
    try:
        number = float(value)  # int, float, numpy scalars, Fractions
    except (TypeError, ValueError):
        raise error(f"{what} must be a number ({valid}), got {value!r}") from None
    if not math.isfinite(number):
        raise error(f"{what} = {number} is not a finite number: give {valid}")
    return number


def check_law_inputs(A0: float | None, i0: float, sympy_seconds: float,
                     error: type[ValueError] = LongwaveError) -> tuple[float | None, float, float]:
    """(A0, i0, sympy_seconds) as floats if each is a finite number in its range, else ``error`` naming
    the option and the range (A0 in [1e-12, 1e12] or None, |i0| <= 1e12, 0 <= sympy_seconds <= 3600)."""
    lo, hi = A0_RANGE
    if A0 is not None:
        a0 = _real("A0", A0, error, f"{lo:g} <= A0 <= {hi:g}")
        if not lo <= a0 <= hi:
            raise error(f"A0 = {a0:g} is outside {lo:g} <= A0 <= {hi:g}: the initial amplitude must be > 0, and "
                        "the law's terms must stay finite floats")
        A0 = a0
    i0 = _real("i0", i0, error, f"|i0| <= {I0_LIMIT:g}")
    if abs(i0) > I0_LIMIT:
        raise error(f"i0 = {i0:g} is outside |i0| <= {I0_LIMIT:g}: i0 is the contact index of A0")
    seconds = _real("sympy_seconds", sympy_seconds, error, f"0 <= sympy_seconds <= {SYMPY_SECONDS_MAX:g}")
    if not 0 <= seconds <= SYMPY_SECONDS_MAX:
        raise error(f"sympy_seconds = {seconds:g} is outside 0 <= sympy_seconds <= {SYMPY_SECONDS_MAX:g} "
                    "(0 skips sympy's closed-form integration)")
    return A0, i0, seconds


@dataclass(frozen=True)
class LongwaveLaw:
    """Eq. 30 and its solution for one uniform perturbation."""

    P: sympy.Rational
    powers: tuple[sympy.Rational, ...]  # powers p of B on the right-hand side
    coefficients: tuple[float, ...]  # numeric C_p
    symbolic_coefficients: tuple[sympy.Expr, ...]  # C_p with integrals as symbols
    f1_minus_f3: float
    eps: float
    kind: str  # "power law", "exponential", "implicit", "quadrature", "constant"
    law: sympy.Expr | None  # A(i) in A_0, i, i_0 (power law / exponential), symbolic constants
    implicit: sympy.Expr | None  # i(A) for the implicit kind (numeric constants)
    numeric_coefficients: tuple[sympy.Expr, ...] = ()  # C_p with numbers for all but the free parameters

    # --------------------------------------------------------------- equations
    def ode(self, symbolic: bool = True) -> sympy.Eq:
        """(f1 - f3) dB/di = eps sum C_p B^p, B = A^P (Eq. 30)."""
        Bf = sympy.Function("B")(I)
        cs = self.symbolic_coefficients if symbolic else numeric_coefficients(self)
        lhs = (F_SYMBOLS["f1"] - F_SYMBOLS["f3"]) if symbolic else sympy.Float(self.f1_minus_f3, 15)
        rhs = (EPS if symbolic else sympy.Float(self.eps, 15)) * sum(
            (c * Bf**p for c, p in zip(cs, self.powers)), sympy.Integer(0)
        )
        return sympy.Eq(lhs * Bf.diff(I), rhs)

    def rate(self) -> float:
        """lambda_L = eps C / (f1 - f3) for a single power (0 when no term forces the contact)."""
        if not self.coefficients:
            return 0.0
        check_values(self, "the rate lambda_L", LongwaveError)
        return self.eps * self.coefficients[0] / self.f1_minus_f3

    def numeric_law(self) -> sympy.Expr | None:
        """The closed-form A(i) with all constants numeric (A_0, i_0 and free parameters symbolic)."""
        if self.law is None:
            return None
        if not missing_values(self):
            return self.law.xreplace({LAW_RATE: sympy.Float(self.rate(), 17)})
        return self.law.xreplace({LAW_RATE: numeric_rate(self, self.f1_minus_f3)})

    # ------------------------------------------------------------ singular index
    def singular_index(self, a0: float, i0: float = 0.0) -> tuple[float | None, str]:
        """(index, what) where the law reaches A = 0 ("extinction") or A = inf ("blow-up").

        None with the reason when neither happens at a finite index.
        """
        if self.kind == "constant":
            return None, "no perturbation of contact i: A stays constant"
        check_values(self, "the singular index of the law", LongwaveError)
        if a0 <= 0:
            raise LongwaveError(f"the initial amplitude A0 must be > 0, got {a0}")
        P = float(self.P)
        if len(self.powers) == 1:
            p = float(self.powers[0])
            k = self.rate()
            if k == 0:
                return None, "zero coefficient: A stays constant"
            if p == 1.0:
                return None, "exponential law: no finite-index singularity"
            base0 = mpmath.mpf(a0) ** (P * (1 - p))  # mpmath: no overflow for large A0 or p
            index = float(i0 - base0 / ((1 - p) * k))
            if not math.isfinite(index):
                return None, "never singular at a finite index"
            if index <= i0:
                return None, ("decays algebraically" if k < 0 else "grows algebraically") + ", never singular"
            return index, "extinction (A -> 0)" if 1 - p > 0 else "blow-up (A -> inf)"
        return self._singular_by_quadrature(a0, i0)

    def _rhs(self, b):
        """eps-free right-hand side sum C_p B^p in mpmath (no overflow or underflow of B^p)."""
        return sum(c * mpmath.mpf(b) ** float(p) for c, p in zip(self.coefficients, self.powers))

    def _singular_by_quadrature(self, a0: float, i0: float):
        """Eq. 31a by quadrature: the index where B reaches 0 or infinity, if finite."""
        b0 = a0 ** float(self.P)
        scale = self.f1_minus_f3 / self.eps
        f0 = self._rhs(b0)
        if f0 == 0:
            return None, "A0 is a stationary amplitude"
        # the nearest zero of the right-hand side in the direction of motion stops B
        grid = [b0 * 10 ** (k / 50) for k in range(-800, 801)]
        ahead = [b for b in grid if (b < b0 if f0 < 0 else b > b0)]
        ahead.sort(reverse=f0 < 0)
        for b in ahead:
            if (self._rhs(b) > 0) != (f0 > 0):
                return None, "approaches a stationary amplitude (a root of Eq. 41) asymptotically"
        end = 0 if f0 < 0 else mpmath.inf
        with mpmath.workdps(20):
            try:
                span = mpmath.quad(lambda b: 1 / self._rhs(b), [b0, end] if f0 > 0 else [end, b0])
            except (ZeroDivisionError, ValueError):
                return None, "quadrature of Eq. 31a failed"
        span = abs(float(span)) * scale
        if not mpmath.isfinite(span) or span > 1e12:
            return None, "never singular at a finite index"
        return i0 + span, "extinction (A -> 0)" if f0 < 0 else "blow-up (A -> inf)"


def longwave_law(amap: AmplitudeMap, eps: float, seconds: float = 2.0) -> LongwaveLaw:
    """Form Eq. 30 from the map's first equation and solve it (closed form where possible)."""
    if amap.expansion.site_dependent or symbol("i") in amap.expansion.R.free_symbols:
        raise LongwaveError(
            "the long-wave law (Eq. 30) needs a uniform perturbation; this R is site-dependent "
            "(per-bead parameters or i): iterate the map instead"
        )
    P = amap.P
    terms = [t for t in amap.power_terms(1) if t.value != 0 and t.coefficient != 0]
    f13 = float(amap.constants["f1"] - amap.constants["f3"])
    powers = tuple(t.power / P for t in terms)
    # numeric C_p when every parameter has a value; None entries when parameters stay symbolic
    coeffs = tuple(float(t.value) if t.value is not None else None for t in terms)
    # C_p in the user's symbols (parameters not replaced by their values): the symbolic Eq. 30
    symbolic = {t.power: t.coefficient for t in amap.power_terms(1, numeric=False)}
    symb = tuple(symbolic[t.power] for t in terms)
    ints = {integral_symbol(k): sympy.Float(v, 17) for k, v in amap.constants.items()}
    num = tuple(sympy.Float(t.value, 17) if t.value is not None else t.coefficient.xreplace(ints) for t in terms)
    if not terms:
        return LongwaveLaw(P, (), (), (), f13, eps, "constant", A0 + 0 * I, None)
    if len(terms) == 1:
        p = powers[0]
        # separation of variables: int B^-p dB = lambda_L (i - i0)
        k = LAW_RATE
        if p == 1:
            # log(B): B = B0 exp(k (i - i0))
            law_B = B0 * sympy.exp(k * (I - I0))
            kind = "exponential"
        else:
            # B^(1-p)/(1-p): B^(1-p) = B0^(1-p) + (1-p) k (i - i0)
            law_B = (B0 ** (1 - p) + (1 - p) * k * (I - I0)) ** (1 / (1 - p))
            kind = "power law"
        law_A = sympy.powsimp(sympy.powdenest(law_B.xreplace({B0: A0**P}) ** (1 / P), force=True), force=True)
        return LongwaveLaw(P, powers, coeffs, symb, f13, eps, kind, law_A, None, num)
    # several powers: Eq. 31a, closed form if sympy finds one in time
    if any(c is None for c in coeffs):
        return LongwaveLaw(P, powers, coeffs, symb, f13, eps, "quadrature", None, None, num)
    G = reciprocal_integral(coeffs, powers, seconds)
    implicit = None
    kind = "quadrature"
    if G is not None and not G.has(sympy.Integral):
        implicit = sympy.Float(f13 / eps, 17) * (G.xreplace({B: A**P}) - G.xreplace({B: A0**P})) + I0
        kind = "implicit"
    return LongwaveLaw(P, powers, coeffs, symb, f13, eps, kind, None, implicit, num)


def numeric_coefficients(law) -> tuple[sympy.Expr, ...]:
    """C_p of a law (LongwaveLaw or BalanceLaw) as sympy numbers, or expressions in its free parameters."""
    return tuple(sympy.Float(c, 15) if c is not None else nc
                 for c, nc in zip(law.coefficients, law.numeric_coefficients or (None,) * len(law.coefficients)))


def missing_values(law) -> tuple[str, ...]:
    """The free parameters (no value given) in a law's coefficients, sorted."""
    return tuple(sorted({s.name for c in numeric_coefficients(law) if c is not None for s in c.free_symbols}))


def check_values(law, what: str, error: type[ValueError]) -> None:
    """Raise ``error`` naming the parameters ``what`` needs a value for, if any is free."""
    missing = missing_values(law)
    if missing:
        raise error(needs_values(what, missing))


def needs_values(what: str, names) -> str:
    """'<what> cannot be computed without a value for mu: give mu=VALUE ...' (one line, names the fix)."""
    names = list(names)
    return (f"{what} cannot be computed without a value for {', '.join(names)}: give "
            + ", ".join(f"{n}=VALUE" for n in names) + " (a keyword of pulsemap.derive, or --param)")


def numeric_rate(law, scale: float) -> sympy.Expr:
    """lambda_L = eps C / scale as a sympy number, or an expression in the free parameters."""
    if not law.coefficients:
        return sympy.Integer(0)
    return sympy.Float(law.eps, 17) * numeric_coefficients(law)[0] / sympy.Float(scale, 17)


def reciprocal_integral(coeffs, powers, seconds: float) -> sympy.Expr | None:
    """int dB / sum_p C_p B^p (Eq. 31a) if sympy finds it within ``seconds``, else None; the outcome,
    found or not, is cached (derive/sympy_cache.py: a larger bound tries again)."""
    key = f"{[repr(float(c)) for c in coeffs]}|{[str(p) for p in powers]}|{sympy.srepr(B)}"
    return bounded_cached("integrate_reciprocal", key, integrate_reciprocal, (coeffs, powers, B), seconds)


def integrate_reciprocal(coeffs, powers, B: sympy.Symbol) -> sympy.Expr:
    """int dB / sum_p C_p B^p by sympy (run under a time bound: the nsimplify of many C_p and the
    integral itself can take minutes for a high-degree R)."""
    F = sum((sympy.nsimplify(c, rational=False) * B**p for c, p in zip(coeffs, powers)), sympy.Integer(0))
    return sympy.integrate(1 / F, B)


def user_names(law) -> set[str]:
    """The names of the user's symbols in a law's coefficients."""
    return {str(x) for c in law.symbolic_coefficients for x in c.free_symbols if isinstance(x, UserSymbol)}


def rate_symbol(law) -> sympy.Symbol:
    """The rate's symbol as printed: lambda_L, or lambda_L_ (and so on) should a parameter be called so."""
    name, taken = LAW_RATE.name, user_names(law)
    while name in taken:
        name += "_"
    return LAW_RATE if name == LAW_RATE.name else sympy.Symbol(name, real=True)


def law_lines(law, heading: str, rate_name: str, a0: float | None, i0: float,
              cite: str = "", constant_reason: str = "no forcing of contact i") -> list[str]:
    """Text lines of a law (Eq. 30 or a balance law): its ODE, symbolic and numeric, the amplitude law
    (closed form, implicit, constant or by quadrature) and, given A0, its singular index.

    ``law`` is a LongwaveLaw or a balance.BalanceLaw; ``rate_name`` names the denominator of the
    rate lambda_L = eps C / rate_name ("(f1 - f3)"), defined on the line after the law;
    ``cite`` prefixes the integral's name ("Eq. 31a ").
    """
    lines = [heading, f"  {law.ode()}", f"  {law.ode(symbolic=False)}"]
    if law.kind == "constant":
        lines.append(f"Amplitude law: A constant ({constant_reason})")
    elif law.law is not None:
        rate = rate_symbol(law)
        lines.append(f"Amplitude law ({law.kind}):")
        lines.append(f"  A(i) = {law.law.xreplace({LAW_RATE: rate})}")
        value = f"{law.rate():.12g}" if not missing_values(law) else str(numeric_rate(law, law_scale(law)))
        lines.append(f"  where {rate} = eps*C/{rate_name}, C = {law.symbolic_coefficients[0]}: "
                     f"{rate} = {value}")
    elif law.implicit is not None:
        lines.append(f"Amplitude law ({cite}integrated in closed form, implicit):")
        lines.append(f"  i(A) = {law.implicit}")
    elif missing_values(law):
        lines.append(f"Amplitude law: {cite}by numerical quadrature, which needs numbers: "
                     + needs_values("it", missing_values(law)))
    else:
        lines.append(f"Amplitude law: {cite}by numerical quadrature (no closed form within the time bound)")
    if a0 is not None:
        index, what = law.singular_index(a0, i0)
        where = f"at contact index {index:.6g}" if index is not None else ""
        lines.append(f"  from A0 = {a0:g} at i0 = {i0:g}: {what} {where}".rstrip())
    return lines


def law_data(law, exponent, scale: tuple[str, float], a0: float | None, i0: float) -> dict:
    """JSON data of a law (Eq. 30 or a balance law): ODE, terms, closed form and, given A0, the
    singular index. ``exponent`` is B's power of A; ``scale`` names and gives the left-hand factor
    (("f1_minus_f3", ...) or ("K", ...))."""
    out = {
        "kind": law.kind,
        "ode": str(law.ode()),
        "ode_numeric": str(law.ode(symbolic=False)),
        "B": f"A**({exponent})",
        "terms": [
            {"power_of_B": str(p), "coefficient": str(cs), "value": c}
            for p, c, cs in zip(law.powers, law.coefficients, law.symbolic_coefficients)
        ],
        scale[0]: scale[1],
        "eps": law.eps,
        "law": str(law.law.xreplace({LAW_RATE: rate_symbol(law)})) if law.law is not None else None,
        "law_numeric": str(law.numeric_law()) if law.law is not None else None,
        "rate_k": law.rate() if len(law.powers) == 1 and not missing_values(law) else None,  # lambda_L (key kept)
        "rate_symbol": str(rate_symbol(law)) if len(law.powers) == 1 else None,
        "rate_definition": (f"{rate_symbol(law)} = eps*({law.symbolic_coefficients[0]})/{scale[0]}"
                            if len(law.powers) == 1 else None),
        "implicit_i_of_A": str(law.implicit) if law.implicit is not None else None,
    }
    if a0 is not None:
        index, what = law.singular_index(a0, i0)
        out.update(A0=a0, i0=i0, singular_index=index, singular_kind=what)
    return out


def law_scale(law) -> float:
    """The left-hand factor of a law: f1 - f3 (Eq. 30) or K (a balance law)."""
    return law.f1_minus_f3 if hasattr(law, "f1_minus_f3") else law.K


def rate_latex(law, denominator: sympy.Expr, lx) -> str:
    """LaTeX of the rate's definition, lambda_L = eps C / denominator, for the line after the law."""
    rate = rate_symbol(law)
    return rf"\text{{where }} {lx(rate)} = {lx(EPS * law.symbolic_coefficients[0] / denominator)}"
