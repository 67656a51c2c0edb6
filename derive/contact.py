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

Elastic correction P = c d^a (b = 0, :func:`elastic_constants`). At fixed speed nu = A^s the perturbed wave is
g = A (S + eps c A^(a-n) h) + O(eps^2), where h is the even solution of the linearised fixed point of Eq. 4,

    h = Lambda * (n S^(n-1) h + S^a)     (Lambda the hat function; S = Lambda * S^n is the unperturbed wave),

solved on the profile's FFT grid. Its peak is A (S0 + eps c A^(a-n) h(0)) and its energy (same lattice-sum =
integral identity as E_1) E_1 A^(n+1) (1 + eps c A^(a-n) e_h / E_1), e_h = int X' X_h' + int S^n h +
int S^(a+1)/(a+1), X_h' = sum_(k>=0) h'(tau - k). Hence:
  * speed at fixed peak P (A_P = P/S0): nu = A_P^s (1 + sigma eps c A_P^(a-n)), sigma = -s h(0)/S0;
  * entry jump, energy carried across the start of the correction (what is shed is a small wave, energy
    O(eps^(n+1))): P'/P0 = 1 + J eps c A0^(a-n), J = h(0)/S0 - e_h / ((n+1) E_1).

Masses (first order, slowly varying m): E does not depend on m, so A and the strain peak A S0 stay constant and
a bead's velocity peak is V_1 A^(1+s) m^(-1/2), V_1 = max_tau X'(tau) (:func:`taper_law`).

The map (Eqs. 16-23) gains eps (P_(k-1) - 2 P_k + P_(k+1)) in each contact's strain equation: its half-line
integrals are :func:`contact_map_terms`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from functools import lru_cache
from typing import Iterable, Mapping

import mpmath
import numpy as np
import sympy

from .balance import BalanceDerivation
from .errors import PulsemapError
from .balance_constants import balance_constants, window
from .balance_law import EPS, BalanceLaw, law_from_groups
from .expansion import exact_exponent
from .expression import symbol
from .integrals import Constant, cached_constants, scalar_funcs
from .longwave import law_data, law_lines
from .profile import NPU, check_exponent, exact_profile, get_profile
from .sources import CONTACT_METHOD

__all__ = [
    "EPS_C", "EPS_S", "HALF_LINE_TAGS", "ContactDerivation", "ContactError", "ContactMonomial", "ElasticConstants",
    "TaperLaw", "amplitude_terms", "bead_velocity_factor", "check_contact_model", "combined_energy_law",
    "contact_constants", "contact_energy_law", "contact_integral_name", "contact_map_terms", "contact_monomials",
    "contact_to_json", "contact_to_text", "derive_contact", "elastic_constants", "first_order_profile",
    "half_line_integral_name", "taper_law",
]

#: The printed factors of the two perturbations in a combined law.
EPS_S = sympy.Symbol("epsilon_s", positive=True)
EPS_C = sympy.Symbol("epsilon_c", positive=True)
#: Names P must not use: the on-site state and bead index belong to R.
FORBIDDEN = ("u", "v", "i")
#: Grid points per unit of tau for the elastic linear solve (a stride of the profile's NPU).
ELASTIC_NPU = 32


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
    groups: dict = {}
    for t in onsite.expansion.terms:
        groups[t.power] = groups.get(t.power, sympy.Integer(0)) + EPS_S * t.coefficient * sympy.Symbol(t.integral, real=True)
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


# ------------------------------------------------------------------------------ elastic correction
@dataclass(frozen=True)
class ElasticConstants:
    """First-order constants of an elastic correction P = c d^a (module docstring), from the exact profile.

    jump: P'/P0 = 1 + jump eps c A0^(a-n) where the correction starts; speed: nu = A^s (1 + speed eps c A^(a-n))
    at fixed peak A S0; h0: h(0)/S0; energy: e_h/E_1; accuracy: a bound on each constant's error.
    """

    n: float
    a: sympy.Rational
    h0: float
    energy: float
    jump: float
    speed: float
    accuracy: float

    def jump_equation(self) -> sympy.Eq:
        """P'/P0 = 1 + jump eps c A0^(a-n) as a sympy Eq (c and eps symbolic)."""
        c, a0, ratio = sympy.symbols("c A_0 P'/P_0", real=True)
        return sympy.Eq(ratio, 1 + sympy.Float(self.jump, 12) * EPS * c * a0 ** (self.a - exact_exponent(self.n)))

    def speed_equation(self) -> sympy.Eq:
        """nu = A^s (1 + speed eps c A^(a-n)) at fixed peak A S0, as a sympy Eq."""
        c, a, nu = sympy.Symbol("c", real=True), sympy.Symbol("A", positive=True), sympy.Symbol("nu", positive=True)
        n = exact_exponent(self.n)
        return sympy.Eq(nu, a ** ((n - 1) / 2) * (1 + sympy.Float(self.speed, 12) * EPS * c * a ** (self.a - n)))


def _coarse_wave(n: float, stride: int):
    """(tau, S, S', h) of the exact profile on every ``stride``-th node of its periodic FFT grid."""
    prof = exact_profile(n)
    nodes = prof.nodes[::stride]
    m = len(nodes)
    step = prof.h * stride
    tau = prof.tau0 + step * np.arange(m)
    return tau, nodes[:, 0].copy(), nodes[:, 1].copy(), step, prof


def first_order_profile(n: float, a, stride: int = NPU // ELASTIC_NPU) -> tuple[np.ndarray, np.ndarray, float]:
    """(tau, h, grid step): the even solution of h = Lambda * (n S^(n-1) h + S^a) on the coarse FFT grid."""
    tau, S, _, step, _ = _coarse_wave(n, stride)
    m = len(tau)
    k = 2.0 * np.pi * np.fft.rfftfreq(m, d=step)
    hat = np.sinc(k / (2.0 * np.pi)) ** 2
    kernel = np.fft.irfft(hat, n=m)  # the circulant matrix of Lambda * on this grid
    Sp = np.maximum(S, 0.0)
    conv = kernel[(np.arange(m)[:, None] - np.arange(m)[None, :]) % m]
    M = np.eye(m) - conv * (n * Sp ** (n - 1.0))[None, :]
    rhs = np.fft.irfft(hat * np.fft.rfft(Sp ** float(a)), n=m)
    centre = int(np.argmin(np.abs(tau)))
    half = m // 2
    # even functions: h at centre + j equals h at centre - j (indices mod m); unknowns j = 0..half
    expand = np.zeros((m, half + 1))
    for j in range(m):
        expand[j, min((j - centre) % m, (centre - j) % m)] = 1.0
    rows = [(centre + j) % m for j in range(half + 1)]
    x = np.linalg.solve((M @ expand)[rows], rhs[rows])
    return tau, expand @ x, step


def _spectral_derivative(f: np.ndarray, step: float) -> np.ndarray:
    m = len(f)
    k = 2.0 * np.pi * np.fft.rfftfreq(m, d=step)
    return np.fft.irfft(1j * k * np.fft.rfft(f), n=m)


def _bead_sum(f: np.ndarray, per_unit: int) -> np.ndarray:
    """sum_{k >= 0} f(tau - k) on a grid with ``per_unit`` nodes per unit of tau (zero-filled shifts)."""
    out = f.copy()
    for k in range(1, len(f) // per_unit):
        out[k * per_unit:] += f[: len(f) - k * per_unit]
    return out


@lru_cache(maxsize=32)
def elastic_constants(n: float = 1.5, a=None) -> ElasticConstants:
    """The entry jump and speed constants of the elastic correction c d^a (default a = n + 1)."""
    n = check_exponent(n)
    a = exact_exponent(n) + 1 if a is None else sympy.Rational(a)
    if not a > 0:
        raise ContactError(f"an elastic correction c*d^a needs a > 0 (a force at zero overlap otherwise), got a = {a}")
    coarse, fine = _elastic_on_grid(n, a, NPU // ELASTIC_NPU * 2), _elastic_on_grid(n, a, NPU // ELASTIC_NPU)
    prof = exact_profile(n)
    # error bound: the change from half the grid (spectral: the finer grid is far better) plus the profile's own
    accuracy = max(abs(x - y) for x, y in zip(coarse, fine)) + prof.accuracy * max(1.0, abs(fine[1]))
    h0, energy = fine
    s = (n - 1.0) / 2.0
    return ElasticConstants(n, a, h0, energy, h0 - energy / (n + 1.0), -s * h0, accuracy)


def _elastic_on_grid(n: float, a: sympy.Rational, stride: int) -> tuple[float, float]:
    """(h(0)/S0, e_h/E_1) from the solve on every ``stride``-th node of the profile's grid."""
    tau, S, dS, step, prof = _coarse_wave(n, stride)
    _, h, _ = first_order_profile(n, a, stride)
    per_unit = NPU // stride
    Sp = np.maximum(S, 0.0)
    dh = _spectral_derivative(h, step)
    e_h = step * float(np.sum(_bead_sum(dS, per_unit) * _bead_sum(dh, per_unit))
                       + np.sum(Sp**n * h) + np.sum(Sp ** (float(a) + 1)) / (float(a) + 1))
    consts = balance_constants(["K1", "V1"], n=n)
    return float(h[int(np.argmin(np.abs(tau)))]) / prof.S0, e_h / (consts["K1"].value + consts["V1"].value)


# ------------------------------------------------------------------------------ masses
@lru_cache(maxsize=16)
def bead_velocity_factor(n: float = 1.5) -> float:
    """V_1 = max_tau X'(tau), X' = sum_(k>=0) S'(tau - k): a bead's velocity peak is V_1 A^(1+s) for unit mass."""
    n = check_exponent(n)
    prof = exact_profile(n)
    L = window(n)
    _, dS, d2S = scalar_funcs(prof)

    def bead_sum(f, t):
        return sum((f(t - k) for k in range(max(0, math.ceil(float(t)) - L), math.floor(float(t)) + L + 1)),
                   mpmath.mpf(0))

    grid = np.arange(-L, L, 1.0 / 64)
    speeds = [float(bead_sum(dS, mpmath.mpf(t))) for t in grid]
    t0 = grid[int(np.argmax(speeds))]
    with mpmath.workdps(16):
        top = mpmath.findroot(lambda t: bead_sum(d2S, t), mpmath.mpf(t0))
        return float(bead_sum(dS, top))


@dataclass(frozen=True)
class TaperLaw:
    """First-order mass law: strain peak constant, bead velocity peak V_1 (P/S0)^(1+s) m_i^(-1/2)."""

    n: float
    S0: float
    V1: float

    def velocity_peak(self, strain_peak: float, mass: float) -> float:
        """A bead's velocity peak for a wave of strain peak ``strain_peak`` on a bead of mass ``mass``."""
        s = (self.n - 1.0) / 2.0
        return self.V1 * (strain_peak / self.S0) ** (1.0 + s) * mass**-0.5

    def equations(self) -> tuple[sympy.Eq, sympy.Eq]:
        """(P_i = P_0, v_i = V_1 (P_0/S0)^(1+s) m_i^(-1/2)) as sympy Eqs."""
        p_i, p0, v_i, m_i = sympy.symbols("P_i P_0 v_i m_i", positive=True)
        s = (exact_exponent(self.n) - 1) / 2
        return (sympy.Eq(p_i, p0),
                sympy.Eq(v_i, sympy.Float(self.V1, 15) * (p0 / sympy.Float(self.S0, 15)) ** (1 + s) / sympy.sqrt(m_i)))


def taper_law(n: float = 1.5) -> TaperLaw:
    """The first-order taper law for exponent n (module docstring)."""
    n = check_exponent(n)
    return TaperLaw(n, get_profile("exact", n).S0, bead_velocity_factor(n))
