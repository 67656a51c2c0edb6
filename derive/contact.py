"""Perturbations of the contact law and of the masses (beyond the paper): energy law, elastic constants, tapers.

The chain m_i x_i'' = F(d_{i-1}, w_{i-1}) - F(d_i, w_i), d_i = x_i - x_{i+1}, w_i = d_i', with

    F(d, w) = H(d) (d^n + eps P(d, w)),   P = sum_j c_j d^(a_j) w^(b_j)   (a_j >= 0 rational, b_j >= 0 integer)

loses energy only through P: dH/dt = -eps sum_k H(d_k) P(d_k, w_k) w_k (masses never enter H's balance).

Work per contact. The exact wave of scale A (derive/balance.py) passes contact k as d = A S(A^s t/sqrt(m) - k),
w = A^(1+s) m^(-1/2) S', s = (n - 1)/2: with beads of mass m the wave is the unit-mass one with time scaled by
sqrt(m) (m x'' = F), so strain and energy are unchanged and velocities carry m^(-1/2). A monomial c d^a w^b does

    W = -eps c int d^a w^(b+1) dt = -eps c m^(-b/2) I_ab A^(a + (1+s)(b+1) - s),   I_ab = int S^a S'^(b+1) dtau,

I_ab = 0 for even b (S even, S' odd: no work). With the wave's energy E = E_1 A^(n+1) (E_1 = K_1 + V_1, the
kinetic and contact energy of all beads of the unit wave, derive/balance_constants.py), the energy law per contact is

    E_1 dB/dk = -eps sum_j c_j m^(-b_j/2) I_(a_j b_j) A^(p_j),  B = A^(n+1)
    i.e. dA/dk = -eps sum_j c_j m^(-b_j/2) I_(a_j b_j) A^(q_j) / ((n + 1) E_1),  q = a + (b+1)(n+1)/2 - (3n-1)/2.

The elastic correction's entry jump and speed and the taper law: derive/contact_wave.py.

The map (Eqs. 16-23) gains eps (P_(k-1) - 2 P_k + P_(k+1)) in each contact's strain equation: its half-line
integrals are :func:`contact_map_terms`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Iterable, Mapping

import mpmath
import sympy

from .balance import BalanceDerivation
from .errors import PulsemapError
from .balance_constants import balance_constants, window
from .balance_law import BalanceLaw, expansion_groups, law_from_groups
from .contact_wave import elastic_constants
from .expansion import exact_exponent
from .expression import symbol
from .integrals import Constant, cached_constants, scalar_funcs
from .longwave import law_data, law_lines
from .profile import check_exponent, get_profile
from .sources import CONTACT_METHOD

__all__ = [
    "EPS_C", "EPS_S", "HALF_LINE_TAGS", "ContactDerivation", "ContactError", "ContactMonomial", "amplitude_terms",
    "check_contact_model", "combined_energy_law", "contact_constants", "contact_energy_law", "contact_integral_name",
    "contact_map_terms", "contact_monomials", "contact_to_json", "contact_to_text", "derive_contact",
    "half_line_integral_name",
]

#: The printed factors of the two perturbations in a combined law.
EPS_S = sympy.Symbol("epsilon_s", positive=True)
EPS_C = sympy.Symbol("epsilon_c", positive=True)
#: Names P must not use: the on-site state and bead index belong to R.
FORBIDDEN = ("u", "v", "i")


class ContactError(PulsemapError):
    """A contact perturbation P(d, w) or a contact-law request that is not defined (the message says why)."""


@dataclass(frozen=True)
class ContactMonomial:
    """coef * d^a * w^b, one term of the contact perturbation P(d, w) (coef may hold parameter symbols)."""

    coef: sympy.Expr
    a: sympy.Rational
    b: int

    def work_power(self, n) -> sympy.Rational:
        """Power of A in the work per contact: a + (1+s)(b+1) - s."""
        s = (exact_exponent(n) - 1) / 2
        return self.a + (1 + s) * (self.b + 1) - s

    def q(self, n) -> sympy.Rational:
        """Power of A in dA/dk: a + (b+1)(n+1)/2 - (3n-1)/2."""
        n = exact_exponent(n)
        return self.a + sympy.Rational(self.b + 1) * (n + 1) / 2 - (3 * n - 1) / 2

    @property
    def integral(self) -> str:
        return contact_integral_name(self.a, self.b)

    @property
    def dissipative(self) -> bool:
        """Odd b: the term does work on the wave."""
        return self.b % 2 == 1


# ------------------------------------------------------------------------------ input form
def _named(expr: sympy.Expr, name: str) -> sympy.Symbol | None:
    return next((x for x in expr.free_symbols if x.name == name), None)


def _rational(x: sympy.Expr) -> sympy.Rational | None:
    if isinstance(x, sympy.Rational):
        return x
    if isinstance(x, sympy.Float):
        return sympy.Rational(str(Fraction(str(float(x)))))
    return None


def contact_monomials(P: sympy.Expr) -> tuple[ContactMonomial, ...]:
    """P(d, w) split into monomials c d^a w^b (a >= 0 rational, b >= 0 integer), or ContactError naming the fix."""
    if not isinstance(P, sympy.Expr):
        raise ContactError(f"P must be a sympy expression in d and w, got {type(P).__name__}")
    used = sorted(x.name for x in P.free_symbols if x.name in FORBIDDEN)
    if used:
        raise ContactError(f"P uses {', '.join(used)}: a contact law is written in d (overlap), w = d' and "
                           "parameters; put on-site terms in R")
    d, w = _named(P, "d"), _named(P, "w")
    state = [x for x in (d, w) if x is not None]
    table: dict[tuple[sympy.Rational, int], sympy.Expr] = {}
    for term in sympy.Add.make_args(sympy.expand(P)):
        if term == 0:
            continue
        coef, rest = term.as_independent(*state, as_Add=False) if state else (term, sympy.Integer(1))
        powers = rest.as_powers_dict() if rest != 1 else {}
        if any(base not in state for base in powers) or any(_rational(e) is None for e in powers.values()):
            raise ContactError(f"P is not a finite sum of c*d^a*w^b (term {term}): write P as such a sum, "
                               "a >= 0 rational, b >= 0 integer")
        a = _rational(sympy.sympify(powers.get(d, 0))) if d is not None else sympy.Integer(0)
        b = _rational(sympy.sympify(powers.get(w, 0))) if w is not None else sympy.Integer(0)
        if a < 0:
            raise ContactError(f"P has a negative power of d (term {term}): the force would diverge at zero overlap")
        if not b.is_integer or b < 0:
            raise ContactError(f"P has the power {b} of w (term {term}): powers of w must be non-negative integers")
        if a == 0 and b == 0:
            raise ContactError(f"P(0+, 0) = {coef} != 0 (term {term}): a force at zero overlap; every term needs "
                               "a positive power of d or a power of w")
        if coef.has(sympy.zoo, sympy.oo, -sympy.oo, sympy.nan) or coef.has(sympy.I):
            raise ContactError(f"P's coefficient {coef} (term {term}) is not a finite real number or parameter "
                               "expression: check for division by zero")
        table[(a, int(b))] = table.get((a, int(b)), sympy.Integer(0)) + coef
    return tuple(ContactMonomial(sympy.factor_terms(c), a, b) for (a, b), c in sorted(table.items()) if c != 0)


# ------------------------------------------------------------------------------ constants
def contact_integral_name(a, b: int) -> str:
    """I_a_b: int S^a S'^(b+1) dtau (a as an exact rational, "I_1/2_1")."""
    return f"I_{sympy.Rational(a)}_{int(b)}"


#: The map's half-line integrals J<tag>_a_b = int_(-inf)^0 S(tau + shift)^a S'(tau + shift)^b dtau, by shift.
HALF_LINE_TAGS = {1: "Jp1", 0: "J0", -1: "Jm1", -2: "Jm2"}


def half_line_integral_name(shift: int, a, b: int) -> str:
    """J<tag>_a_b (tag p1, 0, m1, m2 for shift 1, 0, -1, -2): int_(-inf)^0 S(tau + shift)^a S'(tau + shift)^b."""
    if shift not in HALF_LINE_TAGS:
        raise ContactError(f"half-line integrals exist for shifts {sorted(HALF_LINE_TAGS)}, got {shift}")
    return f"{HALF_LINE_TAGS[shift]}_{sympy.Rational(a)}_{int(b)}"


def _parse_integral_name(name: str) -> tuple[int | None, sympy.Rational, int]:
    """(shift, a, b) of J<tag>_a_b, or (None, a, b) of I_a_b."""
    parts = name.split("_")
    shifts = {tag: shift for shift, tag in HALF_LINE_TAGS.items()}
    if len(parts) == 3 and (parts[0] == "I" or parts[0] in shifts):
        try:
            a, b = sympy.Rational(parts[1]), int(parts[2])
        except (TypeError, ValueError):
            a, b = None, -1
        if a is not None and a >= 0 and b >= 0 and (parts[0] == "I" or a + b > 0):
            return shifts.get(parts[0]), a, b
    raise ContactError(f"unknown contact integral {name!r}: use I_a_b or J<p1|0|m1|m2>_a_b (a >= 0 rational, "
                       "b >= 0 integer, a + b > 0 for J)")


def _compute_integral(prof, name: str, dps: int) -> tuple[float, float]:
    """I_ab = int S^a S'^(b+1) dtau over |tau| <= L, or J_ab = int_(-L)^shift S^a S'^b (the integrand is zero where
    S <= 0: the contact is open)."""
    shift, a, b = _parse_integral_name(name)
    power = b + 1 if shift is None else b
    S, dS, _ = scalar_funcs(prof)
    L = window(prof.n)
    top = L if shift is None else shift
    with mpmath.workdps(dps):
        ea = mpmath.mpf(a.p) / a.q

        def f(t):
            s = S(t)
            return s**ea * dS(t) ** power if s > 0 else mpmath.mpf(0)

        value, err = mpmath.quad(f, list(range(-L, top + 1)), error=True)
        value, err = float(value), float(err)
    if not math.isfinite(value):
        raise ContactError(f"contact integral {name} did not converge (non-finite value)")
    bound = (power + 1 + float(a)) * prof.accuracy * prof.S0 * max(1.0, abs(value)) if prof.kind == "exact" else 0.0
    return value, abs(err) + bound


def contact_constants(names: Iterable[str], *, n: float = 1.5, profile: str = "exact", dps: int | None = None,
                      use_cache: bool = True, budget=None) -> dict[str, Constant]:
    """The integrals I_ab and J<tag>_ab called ``names`` (mpmath, cached on disk like the map's constants)."""
    return cached_constants(
        "contact", names, n=n, profile=profile, dps=dps, use_cache=use_cache,
        key=lambda prof, dps: f"contact-v{CONTACT_METHOD}|{prof.kind}|n={prof.n!r}|dps={dps}|L={window(prof.n)}",
        check_name=_parse_integral_name, compute=_compute_integral, error=ContactError, budget=budget)


def check_contact_model(model: str, monomials: Iterable[ContactMonomial]) -> str:
    """Return ``model``, or ContactError when a momentum model meets contact terms (they cannot change momentum)."""
    if model.startswith("momentum") and tuple(monomials):
        raise ContactError(f"{model} refuses contact terms: contact forces are internal and leave the total momentum "
                           "unchanged, so a momentum balance cannot see them; use energy-map or energy-law")
    return model


# ------------------------------------------------------------------------------ energy law
@dataclass(frozen=True)
class ContactDerivation:
    """The energy law of a contact perturbation with its constants (E1, K1, V1 and the I_ab it uses)."""

    monomials: tuple[ContactMonomial, ...]
    n: float
    profile: str
    eps: float
    mass: sympy.Expr
    constants: dict
    errors: dict
    law: BalanceLaw
    params: dict  # the parameters' values by name
    elastic: tuple  # ElasticConstants of each term c d^a (b = 0), in the order of the monomials

    @property
    def E1(self) -> float:
        return self.constants["K1"] + self.constants["V1"]

    @property
    def P(self) -> sympy.Expr:
        """P(d, w) = sum c d^a w^b."""
        d, w = symbol("d"), symbol("w")
        return sum((m.coef * d**m.a * w**m.b for m in self.monomials), sympy.Integer(0))


def _values(params: Mapping | None, expr_symbols) -> dict:
    """{symbol: value} for the symbols of ``expr_symbols`` named in ``params`` (names or symbols as keys)."""
    by_name = {str(k): v for k, v in (params or {}).items()}

    def number(value) -> sympy.Expr:
        try:
            out = sympy.Integer(value) if isinstance(value, int) else sympy.Float(float(value), 17)
        except (TypeError, ValueError):
            out = None
        if out is None or not out.is_finite:
            raise ContactError(f"a contact parameter's value must be a finite number, got {value!r}")
        return out

    return {x: number(by_name[x.name]) for x in expr_symbols if x.name in by_name}


def _work_groups(monomials, n, mass) -> dict:
    """{power of A: -sum c m^(-b/2) I_ab} over the dissipative monomials (even b does no work)."""
    groups: dict = {}
    for mono in monomials:
        if mono.dissipative:
            p = mono.work_power(n)
            term = -mono.coef * sympy.sympify(mass) ** sympy.Rational(-mono.b, 2) * sympy.Symbol(mono.integral, real=True)
            groups[p] = groups.get(p, sympy.Integer(0)) + term
    return groups


def derive_contact(monomials: Iterable[ContactMonomial], n: float = 1.5, eps: float = 1.0,
                   params: Mapping | None = None, mass=1, profile: str = "exact", dps: int | None = None,
                   seconds: float = 2.0) -> ContactDerivation:
    """The energy law E_1 dB/dk = -eps sum c m^(-b/2) I_ab A^(work power), B = A^(n+1) (module docstring),
    closed form for one power; ``mass`` (number or symbol) is the beads' mass, ``params`` the parameters' values."""
    monomials = tuple(monomials)
    n = check_exponent(n)
    if not math.isfinite(float(eps)):
        raise ContactError(f"eps = {eps!r} must be a finite number")
    indexed = [m for m in monomials if any(x.name == "k" for x in m.coef.free_symbols)]
    if indexed:
        raise ContactError(f"P depends on the contact index k ({indexed[0].coef}): the closed-form law needs a uniform "
                           "P; evaluate it per contact with pulsemap.solvers.models.contact_law.contact_law_peaks")
    mass = sympy.sympify(mass)
    if mass.is_number and not float(mass) > 0:
        raise ContactError(f"mass = {mass} must be > 0")
    names = [m.integral for m in monomials if m.dissipative]
    consts = {**balance_constants(["K1", "V1"], n=n, profile=profile, dps=dps),
              **contact_constants(names, n=n, profile=profile, dps=dps)}
    values = {k: c.value for k, c in consts.items()}
    groups = _work_groups(monomials, n, mass)
    symbols = set().union(*(g.free_symbols for g in groups.values())) if groups else set()
    law = law_from_groups("energy", exact_exponent(n) + 1, groups, values, _values(params, symbols),
                          values["K1"] + values["V1"], float(eps), seconds)
    elastic = tuple(elastic_constants(n, m.a) for m in monomials if m.b == 0)
    return ContactDerivation(monomials, n, profile, float(eps), mass, values, {k: c.error for k, c in consts.items()}, law,
                             {str(k): v for k, v in (params or {}).items()}, elastic)


def contact_to_json(d: ContactDerivation, A0: float | None = None, i0: float = 0.0) -> dict:
    """The contact derivation as JSON-serialisable data: constants, terms, the energy law and elastic constants."""
    c = d.constants
    return {
        "model": "contact-energy-law",
        "P": str(d.P), "eps": d.eps, "mass": str(d.mass), "params": d.params,
        "n": d.n, "profile": d.profile, "S0": get_profile(d.profile, d.n).S0,
        "wave": {"E1": d.E1, "K1": c["K1"], "V1": c["V1"]},
        "constant_errors": d.errors,
        "terms": [{"monomial": str(symbol("d") ** m.a * symbol("w") ** m.b), "coefficient": str(m.coef), "a": str(m.a),
                   "b": m.b, "integral": m.integral if m.dissipative else None,
                   "integral_value": c[m.integral] if m.dissipative else 0.0,
                   "power_of_A_in_work": str(m.work_power(d.n)), "q": str(m.q(d.n))} for m in d.monomials],
        "law": law_data(d.law, d.law.Q, ("K", d.E1), A0, i0),
        "elastic": [{"a": str(e.a), "jump": e.jump, "speed": e.speed, "h0_over_S0": e.h0, "energy_over_E1": e.energy,
                     "accuracy": e.accuracy} for e in d.elastic],
    }


def contact_to_text(d: ContactDerivation, A0: float | None = None, i0: float = 0.0) -> str:
    """A readable report of the contact derivation."""
    c = d.constants
    lines = [
        "Model: contact energy law, E_1 dB/dk = -eps sum c m^(-b/2) I_ab A^(a + (1+s)(b+1) - s), B = A^(n+1)",
        f"P(d, w) = {d.P}    eps = {d.eps:g}    n = {d.n:g}    mass = {d.mass}    profile = {d.profile}",
        f"E_1 = K_1 + V_1 = {c['K1']:.12g} + {c['V1']:.12g} = {d.E1:.12g}",
        "",
        "Terms (monomial: I_ab = int S^a S'^(b+1) dtau, power q of A in dA/dk):",
    ]
    for m in d.monomials:
        value = f"{c[m.integral]:.12g}" if m.dissipative else "0 (even b: no work)"
        lines.append(f"    {m.coef}*d^({m.a})*w^{m.b}: {m.integral} = {value}, q = {m.q(d.n)}")
    lines += [""] + law_lines(d.law, "Law:", "E_1", A0, i0, constant_reason="no work on the wave")
    for e in d.elastic:
        lines.append(f"Elastic d^({e.a}): entry jump P'/P0 = 1 + ({e.jump:.10g}) eps c A0^({e.a - exact_exponent(d.n)}), "
                     f"speed at fixed peak x (1 + ({e.speed:.10g}) eps c A^({e.a - exact_exponent(d.n)}))")
    return "\n".join(lines)


def contact_energy_law(P: sympy.Expr, n: float = 1.5, eps: float = 1.0, params: Mapping | None = None, mass=1,
                       **kw) -> BalanceLaw:
    """The energy law of the contact perturbation P(d, w) (see :func:`derive_contact`)."""
    return derive_contact(contact_monomials(P), n, eps, params, mass, **kw).law


def combined_energy_law(onsite: BalanceDerivation, contact: ContactDerivation, seconds: float = 2.0) -> BalanceLaw:
    """E_1 dB/di = eps_s sum C_p B^p + eps_c sum C'_p B^p: the on-site energy law of derive/balance.py plus the
    contact work (contact k counted at index k, bead i's on-site work at index i as in the on-site law)."""
    check_contact_model(onsite.model, contact.monomials)
    if not isinstance(onsite.law, BalanceLaw):
        raise ContactError("the combined law needs a uniform R; this R is site-dependent: evaluate the terms "
                           "per contact (pulsemap.solvers.models.contact_law)")
    if abs(onsite.n - contact.n) > 0 or onsite.profile != contact.profile:
        raise ContactError("the on-site and contact derivations must use the same n and profile")
    pert = onsite.perturbation
    groups = expansion_groups(onsite.expansion, EPS_S)
    for p, c in _work_groups(contact.monomials, contact.n, contact.mass).items():
        groups[p] = groups.get(p, sympy.Integer(0)) + EPS_C * c
    params = {**pert.scalar_params(), EPS_S: sympy.Float(pert.eps, 17), EPS_C: sympy.Float(contact.eps, 17)}
    contact_syms = set().union(*(m.coef.free_symbols for m in contact.monomials)) if contact.monomials else set()
    params.update(_values(contact.params, contact_syms))
    return law_from_groups("energy", exact_exponent(onsite.n) + 1, groups, {**onsite.constants, **contact.constants},
                           params, contact.E1, 1.0, seconds, eps_symbol=sympy.Integer(1))


def contact_map_terms(monomials: Iterable[ContactMonomial], n: float = 1.5, variant: str = "corrected",
                      profile: str = "exact", dps: int | None = None) -> tuple[sympy.Expr, sympy.Expr | None, dict]:
    """The contact terms of the map's two equations (Eq. 23 with eps (P_(k-1) - 2 P_k + P_(k+1)) in each contact's
    strain equation), integrated over (-inf, T_i] with each contact's own amplitude and time scale:

        F1 += eps sum c [A_(i-1)^e Jp1_ab - 2 A_i^e J0_ab + A_(i+1)^e Jm1_ab]
        F2 += eps sum c [A_i^e J0_ab - 2 A_(i+1)^e Jm1_ab (+ A_(i+1)^e Jm2_ab, variant corrected)]

    e = a + (1+s) b - s, J<shift>_ab = int_(-inf)^0 S(tau + shift)^a S'(tau + shift)^b dtau; variant 1d puts
    A_(i+1) -> A_i in F1 and has no F2. Returns (F1 term, F2 term or None, {J name: value}); P is polynomial in w
    by construction of the monomials."""
    from .amplitude_map import A_I, A_NEXT, A_PREV, EPS as MAP_EPS, check_variant

    variant = check_variant(variant)
    monomials = tuple(monomials)
    n = check_exponent(n)
    s = (exact_exponent(n) - 1) / 2
    J = lambda shift, m: sympy.Symbol(half_line_integral_name(shift, m.a, m.b), real=True)  # noqa: E731
    nxt = A_I if variant == "1d" else A_NEXT
    f1, f2 = sympy.Integer(0), sympy.Integer(0)
    for m in monomials:
        e = m.a + (1 + s) * m.b - s
        f1 += m.coef * (A_PREV**e * J(1, m) - 2 * A_I**e * J(0, m) + nxt**e * J(-1, m))
        f2 += m.coef * (A_I**e * J(0, m) - 2 * A_NEXT**e * J(-1, m)
                        + (A_NEXT**e * J(-2, m) if variant == "corrected" else 0))
    names = sorted({x.name for x in (f1 + f2).free_symbols if x.name[:2] in ("Jp", "J0", "Jm")})
    values = {k: c.value for k, c in contact_constants(names, n=n, profile=profile, dps=dps).items()}
    return MAP_EPS * f1, (MAP_EPS * f2 if variant != "1d" else None), values


def amplitude_terms(law: BalanceLaw) -> tuple[tuple[float, float], ...]:
    """The law K dB/dk = eps sum C_p B^p, B = A^Q, as dA/dk = sum rate A^q: ((q, rate), ...), rate = eps C/(Q K)."""
    Q = float(law.Q)
    if any(c is None for c in law.coefficients):
        raise ContactError("the law has parameters without values: give them values first")
    return tuple((Q * (float(p) - 1) + 1, law.eps * c / (Q * law.K)) for p, c in zip(law.powers, law.coefficients))
