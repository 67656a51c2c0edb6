"""Energy- and momentum-balance reduced models (beyond the paper), derived like Eqs. 23 and 30.

The travelling wave of scale A (delta_j = A S(A^s t - j), s = (n - 1)/2, Eqs. 4, 7) moves bead 0
as x(t) = A X(tau), x'(t) = A^(1+s) X'(tau), tau = A^s t, with

    X(tau) = sum_{k >= 0} S(tau - k)        (x_i = sum_{k >= i} delta_k)

X rises from 0 to D = int S dtau (sum_m S(m + theta) = D for every theta: summing Eq. 4 over m
gives a periodic function with zero second derivative). The unperturbed chain conserves

    E = sum x'^2/2 + sum delta^(n+1)/(n+1) = E_1 A^(n+1),  E_1 = K_1 + V_1,
        K_1 = int X'^2/2 dtau,  V_1 = int S_+^(n+1)/(n+1) dtau
    p = sum x'                            = p_1 A^(1+s),  p_1 = int X' dtau (= D)

(a lattice sum at fixed time equals the time integral because the sum is constant in time).
When the wave passes a perturbed bead, eps R(u, v) = eps sum c_ab u^a v^b does

    work     W(A) = eps int R x' dt = eps sum c_ab A^(a + (1+s)(b+1) - s) w_ab,  w_ab = int X^a X'^(b+1) dtau
    impulse  J(A) = eps int R dt    = eps sum c_ab A^(a + (1+s) b - s)     j_ab,  j_ab = int X^a X'^b dtau

Energy model: the map E_1 A_i^(n+1) = E_1 A_{i-1}^(n+1) + W(A_{i-1}) (bead i, between contacts i-1
and i) and the law E_1 dB/di = eps sum_p C_p B^p, B = A^(n+1); momentum model likewise with p_1,
J and B = A^(1+s). A term without v (a foundation term c u^a) makes the impulse diverge (the bead
ends displaced by A D and the force keeps acting): the momentum model refuses such R.

Profiles: every integral is over |tau| <= L with the profile truncated to |tau| <= L,
L = ceil(tail of the exact profile) + 1 (7 for n = 3/2). For the exact profile this is exact to
1e-15; the Pade form (Eq. 5) decays algebraically and its sum_m S(m + theta) is not constant, so
X' never returns to zero and the window is part of its definition. Constants are computed with
mpmath.quad on unit sub-intervals and cached on disk like the map's (derive/cache.py).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable, Iterable

import mpmath
import sympy

from .expansion import bead_symbol, check_polynomial_at_rest, exact_exponent
from .expression import symbol
from .integrals import Constant, _scalar_funcs, cached_constants
from .longwave import LAW_RATE, A0, I, I0, check_law_inputs, law_data, law_lines, rate_latex, rate_symbol
from .perturbation import Perturbation, param_data
from .provenance import provenance
from .profile import check_exponent, check_profile_kind, exact_profile, get_profile
from .site_law import SiteLaw, coefficient_of_i, site_law
from .sources import BALANCE_METHOD, DEFAULT_DPS
from .sources import BALANCE_MODELS as MODELS
from .timebox import bounded

B = sympy.Symbol("B", positive=True)
A = sympy.Symbol("A", positive=True)
B0 = sympy.Symbol("B_0", positive=True)
K_RATE = LAW_RATE  # lambda_L = eps C / K, defined where a law prints it (longwave.law_lines)
EPS = sympy.Symbol("epsilon", positive=True)
#: The wave's energy and momentum coefficients as printed symbols.
K_SYMBOLS = {"energy": sympy.Symbol("E_1", positive=True), "momentum": sympy.Symbol("p_1", positive=True)}
#: The wave's constants every model needs (E_1 = K1 + V1).
WAVE_NAMES = {"energy": ("K1", "V1"), "momentum": ("p1",)}


class BalanceError(ValueError):
    """A balance model that is undefined or cannot be built for this R (the message says why)."""


def check_model(model: str) -> str:
    """Return the balance model name, or raise a one-line error naming the known ones."""
    if model not in MODELS:
        raise BalanceError(f"unknown balance model {model!r}: choose one of {', '.join(MODELS)}")
    return model


def window(n: float) -> int:
    """Half-width L of the tau window: ceil(tail of the exact profile) + 1."""
    return int(math.ceil(exact_profile(check_exponent(n)).tail)) + 1


def integral_name(model: str, a: int, b: int) -> str:
    """w_ab (energy: int X^a X'^(b+1)) or j_ab (momentum: int X^a X'^b); '_' between digits past 9."""
    sep = "" if max(a, b) < 10 else "_"
    return ("w_" if model == "energy" else "j_") + f"{a}{sep}{b}"


def _parse_name(name: str) -> tuple[str, int, int]:
    if name in ("K1", "V1", "p1", "D"):
        return name, 0, 0
    if len(name) > 2 and name[:2] in ("w_", "j_"):
        body = name[2:]
        parts = body.split("_") if "_" in body else list(body)
        if len(parts) == 2 and all(p.isdigit() for p in parts):
            a, b = int(parts[0]), int(parts[1])
            if name[0] == "w" or b >= 1:
                return name[0], a, b
            raise BalanceError(f"{name} = int X^{a} dtau diverges (the bead ends displaced): impulse integrals need b >= 1")
    raise BalanceError(f"unknown balance integral {name!r}: use K1, V1, p1, D, w_ab or j_ab")


# ------------------------------------------------------------------------- constants
def _bead_motion(S: Callable, dS: Callable, L: int) -> tuple[Callable, Callable]:
    """X(tau) = sum_{k>=0} S(tau - k) and X'(tau), with S truncated to |tau| <= L."""

    def terms(t, f):
        k0 = max(0, math.ceil(float(t) - L))
        k1 = math.floor(float(t) + L)
        return sum((f(t - k) for k in range(k0, k1 + 1)), mpmath.mpf(0))

    return (lambda t: terms(t, S)), (lambda t: terms(t, dS))


def _compute(profile, name: str, dps: int, L: int) -> tuple[float, float]:
    S, dS, _ = _scalar_funcs(profile)
    X, dX = _bead_motion(S, dS, L)
    n = mpmath.mpf(profile.n)
    kind, a, b = _parse_name(name)
    if kind == "K1":
        f = lambda t: dX(t) ** 2 / 2  # noqa: E731
    elif kind == "V1":
        f = lambda t: (S(t) ** (n + 1) / (n + 1)) if S(t) > 0 else mpmath.mpf(0)  # noqa: E731
    elif kind == "p1":
        f = dX
    elif kind == "D":
        f = S
    elif kind == "w":
        f = lambda t: X(t) ** a * dX(t) ** (b + 1)  # noqa: E731
    else:
        f = lambda t: X(t) ** a * dX(t) ** b  # noqa: E731
    with mpmath.workdps(dps):
        value, err = mpmath.quad(f, list(range(-L, L + 1)), error=True)
        value, err = float(value), float(err)
    if not math.isfinite(value):
        raise BalanceError(f"balance integral {name} did not converge (non-finite value)")
    return value, err


def _compute_bounded(prof, name: str, dps: int) -> tuple[float, float]:
    """The integral over |tau| <= L and its error bound: the exact profile is known to accuracy * S0
    pointwise, and the integrand sums 2L + 1 shifted copies of it."""
    L = window(prof.n)
    value, err = _compute(prof, name, dps, L)
    return value, abs(err) + ((2 * L + 1) * prof.accuracy * prof.S0 * max(1.0, abs(value)) if prof.kind == "exact" else 0.0)


def _cache_key(profile, dps: int, L: int) -> str:
    return f"balance-v{BALANCE_METHOD}|{profile.kind}|n={profile.n!r}|dps={dps}|L={L}"


def balance_constants(
    names: Iterable[str], *, n: float = 1.5, profile: str = "exact", dps: int | None = None, use_cache: bool = True
) -> dict[str, Constant]:
    """The wave constants (K1, V1, p1, D) and profile integrals (w_ab, j_ab) called ``names``.

    Computed on demand with mpmath and cached on disk, keyed by (n, profile, dps, window).
    """
    return cached_constants("balance", names, n=n, profile=profile, dps=dps, use_cache=use_cache,
                            key=lambda prof, dps: _cache_key(prof, dps, window(prof.n)),
                            check_name=_parse_name, compute=_compute_bounded, error=BalanceError)


# ------------------------------------------------------------------------- expansion
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


def balance_expand(R: sympy.Expr, n: float | sympy.Rational = 1.5, model: str = "energy", site_dependent: Iterable[str] = ()) -> BalanceExpansion:
    """Expand R = sum c_ab u^a v^b into the work (energy) or impulse (momentum) terms of the model."""
    check_model(model)
    n_exact = exact_exponent(n)
    site = tuple(sorted(site_dependent))
    check_polynomial_at_rest(R, f"the {model} balance integrates R term by term", f"the {model} balance's integrals", BalanceError)
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
            "use the energy balance or the map"
        )
    terms.sort(key=lambda t: (t.power, t.exponents))
    return BalanceExpansion(model, R, n_exact, tuple(terms), site)


# ------------------------------------------------------------------------------ law
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

    def ode(self, symbolic: bool = True) -> sympy.Eq:
        """K dB/di = eps sum C_p B^p with B = A^Q."""
        Bf = sympy.Function("B")(I)
        cs = self.symbolic_coefficients if symbolic else [sympy.Float(c, 15) for c in self.coefficients]
        K = K_SYMBOLS[self.model] if symbolic else sympy.Float(self.K, 15)
        e = EPS if symbolic else sympy.Float(self.eps, 15)
        return sympy.Eq(K * Bf.diff(I), e * sum((c * Bf**p for c, p in zip(cs, self.powers)), sympy.Integer(0)))

    def rate(self) -> float:
        """k = eps C / K for a single power (0 when R does no work / gives no impulse)."""
        if not self.coefficients:
            return 0.0
        return self.eps * self.coefficients[0] / self.K

    def numeric_law(self) -> sympy.Expr | None:
        if self.law is None:
            return None
        return self.law.xreplace({K_RATE: sympy.Float(self.rate(), 17)})

    def _rhs(self, b: float):
        """sum C_p B^p in mpmath (no overflow or underflow of B^p)."""
        return sum(c * mpmath.mpf(b) ** float(p) for c, p in zip(self.coefficients, self.powers))

    def singular_index(self, a0: float, i0: float = 0.0) -> tuple[float | None, str]:
        """(index, what) where A(i) reaches 0 ("extinction") or infinity ("blow-up"), else None and why."""
        if self.kind == "constant":
            return None, "no work on the wave: A stays constant"
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
    Q = ex.Q
    K = constants["K1"] + constants["V1"] if ex.model == "energy" else constants["p1"]
    groups: dict[sympy.Rational, sympy.Expr] = {}
    for t in ex.terms:
        groups[t.power] = groups.get(t.power, sympy.Integer(0)) + t.coefficient * sympy.Symbol(t.integral, real=True)
    powers, coeffs, symb = [], [], []
    for power in sorted(groups):
        sym = sympy.expand(groups[power])
        num = sym.xreplace(params).xreplace({sympy.Symbol(k, real=True): sympy.Float(v, 17) for k, v in constants.items()})
        value = float(num) if not num.free_symbols else None
        if value == 0.0:
            continue
        powers.append(power / Q)
        coeffs.append(value)
        symb.append(sym)
    powers, coeffs, symb = tuple(powers), tuple(coeffs), tuple(symb)
    if not powers:
        return BalanceLaw(ex.model, Q, (), (), (), K, eps, "constant", A0 + 0 * I, None)
    if len(powers) == 1:
        (p,) = powers
        if p == 1:
            law_B = B0 * sympy.exp(K_RATE * (I - I0))
            kind = "exponential"
        else:
            law_B = (B0 ** (1 - p) + (1 - p) * K_RATE * (I - I0)) ** (1 / (1 - p))
            kind = "power law"
        law_A = sympy.powsimp(sympy.powdenest(law_B.xreplace({B0: A0**Q}) ** (1 / Q), force=True), force=True)
        return BalanceLaw(ex.model, Q, powers, coeffs, symb, K, eps, kind, law_A, None)
    if any(c is None for c in coeffs):
        return BalanceLaw(ex.model, Q, powers, coeffs, symb, K, eps, "quadrature", None, None)
    F = sum((sympy.nsimplify(c, rational=False) * B**p for c, p in zip(coeffs, powers)), sympy.Integer(0))
    G = bounded(sympy.integrate, (1 / F, B), seconds)
    if G is not None and not G.has(sympy.Integral):
        implicit = sympy.Float(K / eps, 17) * (G.xreplace({B: A**Q}) - G.xreplace({B: A0**Q})) + I0
        return BalanceLaw(ex.model, Q, powers, coeffs, symb, K, eps, "implicit", None, implicit)
    return BalanceLaw(ex.model, Q, powers, coeffs, symb, K, eps, "quadrature", None, None)


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


# ------------------------------------------------------------------------ derivation
@dataclass(frozen=True)
class BalanceDerivation:
    """A balance model derived for one perturbation, with the choices that produced it."""

    perturbation: Perturbation
    model: str
    n: float
    profile: str
    dps: int
    window: int
    S0: float
    expansion: BalanceExpansion
    constants: dict
    errors: dict
    law: BalanceLaw | SiteLaw | None
    law_note: str
    A0: float | None = None
    i0: float = 0.0
    timings_s: dict = field(default_factory=dict)

    @property
    def K(self) -> float:
        """E_1 (energy) or p_1 (momentum)."""
        c = self.constants
        return c["K1"] + c["V1"] if self.model == "energy" else c["p1"]


def model_title(model: str) -> str:
    return {
        "energy": "energy balance: E(A_i) = E(A_{i-1}) + W(A_{i-1}), E = E_1 A^(n+1), W = eps int R x' dt",
        "momentum": "momentum balance: p(A_i) = p(A_{i-1}) + J(A_{i-1}), p = p_1 A^(1+s), J = eps int R dt",
    }[model]


def derive_balance(
    pert: Perturbation,
    model: str = "energy",
    n: float = 1.5,
    profile: str = "exact",
    A0_value: float | None = None,
    i0: float = 0.0,
    dps: int | None = None,
    sympy_seconds: float = 2.0,
) -> BalanceDerivation:
    """Derive the energy- or momentum-balance map and law for ``pert`` (module docstring)."""
    t0 = time.perf_counter()
    A0_value, i0, sympy_seconds = check_law_inputs(A0_value, i0, sympy_seconds, BalanceError)
    model = check_model(model)
    n = check_exponent(n)
    profile = check_profile_kind(profile)
    ex = balance_expand(pert.R, n, model, pert.site_dependent)
    names = list(ex.wave_names) + ["D"] + list(ex.integrals())
    consts = balance_constants(names, n=n, profile=profile, dps=dps)
    values = {k: c.value for k, c in consts.items()}
    errors = {k: c.error for k, c in consts.items()}
    t1 = time.perf_counter()
    law, note = None, ""
    try:
        if ex.uniform:
            law = balance_law(ex, values, pert.scalar_params(), float(pert.eps), sympy_seconds)
        else:
            law = balance_site_law(ex, pert, values, sympy_seconds)
    except BalanceError as exc:
        note = str(exc)
    t2 = time.perf_counter()
    return BalanceDerivation(
        perturbation=pert, model=model, n=n, profile=profile,
        dps=int(dps if dps is not None else DEFAULT_DPS[profile]), window=window(n),
        S0=get_profile(profile, n).S0, expansion=ex, constants=values, errors=errors, law=law, law_note=note,
        A0=A0_value, i0=i0, timings_s={"integrals": t1 - t0, "law": t2 - t1, "total": t2 - t0},
    )


# ------------------------------------------------------------------------- rendering
def map_equation(d: BalanceDerivation, numeric: bool = False) -> sympy.Eq:
    """K A_i^Q = K A_{i-1}^Q + eps sum c A_{i-1}^power integral (bead i's parameters)."""
    a_prev, a_i = sympy.symbols("A_{i-1} A_i", positive=True)
    K = sympy.Float(d.K, 15) if numeric else K_SYMBOLS[d.model]
    e = sympy.Float(d.perturbation.eps, 15) if numeric else EPS
    rate = d.expansion.rate(a_prev, d.constants if numeric else None)
    return sympy.Eq(K * a_i**d.expansion.Q, K * a_prev**d.expansion.Q + e * rate)


def json_header(model: str, pert: Perturbation) -> dict:
    """The first fields of every derivation's JSON (map or balance model): the model, provenance and
    the perturbation (expression, R, eps, parameters)."""
    return {
        "model": model,
        "provenance": provenance(),
        "expression": pert.text,
        "R": str(pert.R),
        "eps": pert.eps,
        "params": {k: param_data(v) for k, v in pert.params.items()},
    }


def to_json(d: BalanceDerivation) -> dict:
    """The balance derivation as JSON-serialisable data; ``model`` names it."""
    law = d.law
    if isinstance(law, SiteLaw):
        law_json = law.data()
    else:
        law_json = law_data(law, law.Q, ("K", law.K), d.A0, d.i0) if law is not None else None
    c = d.constants
    wave = ({"E1": d.K, "K1": c["K1"], "V1": c["V1"], "kinetic_fraction": c["K1"] / d.K} if d.model == "energy"
            else {"p1": c["p1"]})
    return {
        **json_header(d.model, d.perturbation),
        "title": model_title(d.model),
        "n": d.n,
        "profile": d.profile,
        "dps": d.dps,
        "window_L": d.window,
        "S0": d.S0,
        "D": c["D"],
        "wave": wave,
        "Q": str(d.expansion.Q),
        "constant_errors": d.errors,
        "terms": [{"exponents": list(t.exponents), "monomial": str(t.monomial), "coefficient": str(t.coefficient),
                   "integral": t.integral, "integral_value": c[t.integral], "power_of_A": str(t.power)}
                  for t in d.expansion.terms],
        "site_dependent": list(d.expansion.site_dependent),
        "map": {"equation": str(map_equation(d)), "equation_numeric": str(map_equation(d, numeric=True))},
        "law": law_json,
        "law_note": d.law_note or None,
        "timings_s": {k: round(v, 6) for k, v in d.timings_s.items()},
    }


def to_text(d: BalanceDerivation) -> str:
    """A readable report of the balance derivation."""
    c = d.constants
    ex = d.expansion
    kname = "E_1" if d.model == "energy" else "p_1"
    what = "work W/eps = int R x' dt" if d.model == "energy" else "impulse J/eps = int R dt"
    integ = "int X^a X'^(b+1) dtau" if d.model == "energy" else "int X^a X'^b dtau"
    lines = [
        f"Model: {model_title(d.model)}",
        f"R(u, v) = {d.perturbation.R}    eps = {d.perturbation.eps:g}    n = {d.n:g}    profile = {d.profile}",
        f"S(0) = {d.S0:.12g}; bead motion X(tau) = sum_(k>=0) S(tau - k), D = int S = {c['D']:.12g}; "
        f"integrals over |tau| <= {d.window}, mpmath dps {d.dps}",
    ]
    if d.model == "energy":
        lines.append(f"E_1 = K_1 + V_1 = {c['K1']:.12g} + {c['V1']:.12g} = {d.K:.12g}  "
                     f"(kinetic fraction {c['K1'] / d.K:.10g}; virial theorem: (n+1)/(n+3) = {(d.n + 1) / (d.n + 3):.10g})")
    else:
        lines.append(f"p_1 = int X' dtau = {c['p1']:.12g}")
    lines += ["", f"Terms of the {what} (monomial -> coefficient x {integ} x A^power):"]
    for t in ex.terms:
        lines.append(f"    {str(t.monomial):14s} {str(t.coefficient):>14s} x {t.integral} (= {c[t.integral]:.12g}) x A^({t.power})")
    lines += ["", "Map (bead i takes contact i-1 to contact i):", f"  {map_equation(d)}", f"  {map_equation(d, numeric=True)}", ""]
    law = d.law
    if law is None:
        lines.append(f"Law: not available ({d.law_note})")
    elif isinstance(law, SiteLaw):
        lines += law.lines(f"Law, B = A^({law.Q}), bead i + 1/2 at contact index i (R varies along the chain):")
    else:
        lines += law_lines(law, f"Law, B = A^({law.Q}):", kname, d.A0, d.i0,
                           constant_reason="no work on the wave")
    return "\n".join(lines)


def to_latex(d: BalanceDerivation) -> str:
    """The balance map, ODE and law in LaTeX."""
    names = {sympy.Symbol(t.integral, real=True): t.integral[0] + "_{" + t.integral[2:].replace("_", ",") + "}"
             for t in d.expansion.terms}
    lx = lambda e: sympy.latex(e, symbol_names=names)  # noqa: E731
    out = [rf"% pulsemap derivation, model: {d.model} balance; R = {d.perturbation.R}", lx(map_equation(d))]
    if d.law is not None:
        out.append(lx(d.law.ode()))
        if d.law.law is not None:
            out.append(rf"A(i) = {lx(d.law.law.xreplace({LAW_RATE: rate_symbol(d.law)}))}")
            out.append(rate_latex(d.law, K_SYMBOLS[d.model], lx))
    return "\n".join(out)
