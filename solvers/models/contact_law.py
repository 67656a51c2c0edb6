"""The contact perturbation's first-order energy law evaluated along the chain (derive/contact.py).

    dA/dk = -eps sum_j c_j(k) m(k)^(-b_j/2) I_j A^(q_j) / ((n + 1) E_1) + sum_r rate_r(k) A^(q_r)

per contact k: c_j(k) the monomial coefficients with contact k's parameter values, m(k) = (m_k + m_(k+1))/2 the
mass of the beads contact k joins, the optional terms (q_r, rate_r) another law's (an on-site energy law through
``pulsemap.symbolic.contact.amplitude_terms``). Contact k's values hold on [k - 1/2, k + 1/2); the law is
integrated with scipy from the seed peak at the seed contact. The map form steps the energy instead,
A_k^(n+1) = A_(k-1)^(n+1) + (n + 1) sum_j rate_j A_(k-1)^(q_j + n), rate_j the mean of contacts k - 1 and k. A is the energy amplitude (E = E_1 A^(n+1)); the
elastic terms c d^a (b = 0) do no work but shape the wave: the peak at contact k is
A S0 (1 + eps sum J_a c(k) A^(a-n)) (J_a the entry-jump constant, ``elastic_constants``), which also converts the
seed peak to A. A bead's velocity peak is V_1 A(i - 1/2)^(1+s) m_i^(-1/2) (bead i between contacts i - 1 and i;
the unperturbed wave's shape). Even powers b >= 2 of w do no work and are not modelled further. Contacts past the
law's end (extinction or blow-up) carry None, never a NaN.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from pulsemap.symbolic.errors import PulsemapError


class ContactLawError(PulsemapError):
    """A contact law that cannot be evaluated as asked (the message names the fix)."""


@dataclass(frozen=True)
class ContactLawRun:
    """Amplitudes, strain peaks (A S0) and bead-velocity peaks of the contact energy law along the chain."""

    contacts: np.ndarray  # seed contact .. last contact
    A: tuple  # float, or None past the law's end
    peaks: tuple
    beads: np.ndarray  # seed contact + 1 .. last contact
    velocity_peaks: tuple
    status: str  # "ok", "extinction" or "blow-up"
    ended_at: float | None  # contact index where the law ended
    profile: str  # the wave profile of the constants ("exact")
    tolerance: float  # relative tolerance of the law's integration (0: the map is exact arithmetic)
    form: str  # "law" (the ODE) or "map" (energy per contact step)


def _per_contact(name: str, value, count: int, first: int) -> np.ndarray:
    """A parameter's values at contacts first .. first + count - 1 (a number, or a sequence by contact index)."""
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        arr = np.full(first + count, float(arr))
    if arr.ndim != 1 or len(arr) < first + count:
        raise ContactLawError(f"parameter {name!r} has {arr.size} values but contacts up to {first + count - 1} need "
                              f"{first + count} (one per contact, from contact 0): give a longer list")
    out = arr[first:first + count]
    if not np.all(np.isfinite(out)):
        raise ContactLawError(f"parameter {name!r} is not finite at some contact: give finite values")
    return out


def _contact_masses(masses, first: int, count: int) -> tuple[np.ndarray, np.ndarray]:
    """(mass of each contact k = (m_k + m_(k+1))/2, mass of beads first .. first + count) for k = first ..."""
    if masses is None:
        return np.ones(count), np.ones(count + 1)
    m = np.asarray(masses, dtype=float)
    if m.ndim != 1 or len(m) < first + count + 1:
        raise ContactLawError(f"masses has {m.size} values but beads up to {first + count} need {first + count + 1} "
                              "(one per bead, from bead 0): give a longer list")
    m = m[first:first + count + 1]
    if not np.all(np.isfinite(m)) or np.any(m <= 0):
        raise ContactLawError("masses must be finite and > 0: check the mass list")
    return 0.5 * (m[:-1] + m[1:]), m


def _coefficients(mono, given: Mapping[str, object], ks: np.ndarray) -> np.ndarray:
    """A monomial's coefficient at contacts ``ks`` (parameters by name, ``k`` the contact index)."""
    import sympy

    syms = sorted(mono.coef.free_symbols, key=lambda x: x.name)
    args = []
    for x in syms:
        if x.name == "k":
            args.append(ks.astype(float))
        elif x.name in given:
            args.append(_per_contact(x.name, given[x.name], len(ks), int(ks[0])))
        else:
            raise ContactLawError(f"the contact law needs a value for {x.name}: give {x.name}=VALUE in params")
    with np.errstate(all="ignore"):
        value = np.broadcast_to(np.asarray(sympy.lambdify(syms, mono.coef, "numpy")(*args), dtype=float), ks.shape)
    if not np.all(np.isfinite(value)):
        bad = int(ks[np.argmin(np.isfinite(value))])
        raise ContactLawError(f"the coefficient {mono.coef} is not finite at contact {bad}: check its parameters")
    return value.copy()


def contact_law_peaks(
    monomials: Sequence,
    n: float,
    eps: float,
    seed_peak: float,
    seed_contact: int,
    last_contact: int,
    params: Mapping[str, object] | None = None,
    masses: Sequence[float] | None = None,
    extra_terms: Sequence[tuple[float, object]] = (),
    rtol: float = 1e-10,
    death_fraction: float = 1e-6,
    form: str = "law",
) -> ContactLawRun:
    """The energy law of the contact monomials (``pulsemap.symbolic.contact.ContactMonomial``) from the strain peak
    ``seed_peak`` at ``seed_contact`` to ``last_contact``; ``params`` by name (a number or per-contact values),
    ``masses`` per bead, ``extra_terms`` ((q, rate), ...) more terms dA/dk = rate A^q (rate a number or per contact);
    ``form`` "law" integrates the ODE, "map" steps the energy contact by contact."""
    from pulsemap.symbolic.balance_constants import balance_constants
    from pulsemap.symbolic.contact import contact_constants
    from pulsemap.symbolic.contact_wave import bead_velocity_factor, elastic_constants
    from pulsemap.symbolic.profile import exact_profile

    try:
        seed_peak = float(seed_peak)
    except (TypeError, ValueError):
        seed_peak = math.nan
    if not (math.isfinite(seed_peak) and seed_peak > 0):
        raise ContactLawError(f"the seed peak must be a finite number > 0, got {seed_peak!r}")
    if not (0 <= seed_contact < last_contact):
        raise ContactLawError(f"need 0 <= seed contact < last contact, got {seed_contact} and {last_contact}")
    if form not in ("law", "map"):
        raise ContactLawError(f"unknown form {form!r}: choose law or map")
    if not math.isfinite(eps):
        raise ContactLawError(f"eps = {eps!r} must be finite")
    prof = exact_profile(n)
    s = (prof.n - 1.0) / 2.0
    count = last_contact - seed_contact + 1
    mc, mb = _contact_masses(masses, seed_contact, count)
    ks = np.arange(seed_contact, last_contact + 1)
    wave = balance_constants(["K1", "V1"], n=prof.n)
    E1 = wave["K1"].value + wave["V1"].value
    dissipative = [m for m in monomials if m.b % 2 == 1]
    ints = contact_constants([m.integral for m in dissipative], n=prof.n)
    terms: list[tuple[float, np.ndarray]] = []
    given = dict(params or {})
    for mono in dissipative:
        coef = _coefficients(mono, given, ks)
        rate = -eps * coef * mc ** (-mono.b / 2.0) * ints[mono.integral].value / ((prof.n + 1.0) * E1)
        terms.append((float(mono.q(prof.n)), rate))
    for q, rate in extra_terms:
        r = np.asarray(rate, dtype=float)
        terms.append((float(q), np.full(count, float(r)) if r.ndim == 0 else _per_contact("extra term", r, count, seed_contact)))
    # elastic terms c d^a: the peak of the wave of energy amplitude A is A S0 (1 + eps sum J c A^(a-n))
    elastic = [(float(m.a) - prof.n, elastic_constants(prof.n, m.a).jump * eps * _coefficients(m, given, ks))
               for m in monomials if m.b == 0]

    def peak(A: float, j: int) -> float:
        return A * prof.S0 * (1.0 + sum(c[j] * A**e for e, c in elastic))

    A0 = seed_peak / prof.S0
    A0 *= 1.0 - sum(c[0] * A0**e for e, c in elastic)  # the seed's energy amplitude, to first order
    if form == "law":
        amps, half, status, ended = _integrate_law(terms, ks, A0, rtol, death_fraction)
    else:
        amps, half, status, ended = _iterate_map(terms, ks, A0, prof.n, death_fraction)
    A = tuple(amps) + (None,) * (count - len(amps))
    peaks = tuple(peak(x, j) if x is not None else None for j, x in enumerate(A))
    V1 = bead_velocity_factor(prof.n)
    vel = tuple(V1 * half[j] ** (1.0 + s) * mb[j + 1] ** -0.5 if j < len(half) else None for j in range(count - 1))
    return ContactLawRun(ks, A, peaks, ks[1:], vel, status, ended, "exact", rtol if form == "law" else 0.0, form)


def _integrate_law(terms, ks, A0: float, rtol: float, death_fraction: float):
    """dA/dk = sum rate(k) A^q with contact k's rates on [k - 1/2, k + 1/2): (A at ks, A at ks + 1/2, status, end)."""
    from scipy.integrate import solve_ivp

    floor, ceiling = death_fraction * A0, A0 / death_fraction
    amps: list = [A0]
    half: list = []
    status, ended = "ok", None
    a = A0
    for j, k in enumerate(ks):
        rates = [(q, r[j]) for q, r in terms]

        def rhs(_x, y, rates=rates):
            return [sum(r * max(y[0], 0.0) ** q for q, r in rates)]

        def low(_x, y):
            return y[0] - floor

        def high(_x, y):
            return y[0] - ceiling

        low.terminal = high.terminal = True
        start = float(k) if j == 0 else k - 0.5
        stops = [float(k)] if j else []
        sol = solve_ivp(rhs, (start, k + 0.5), [a], method="DOP853", rtol=rtol, atol=rtol * floor,
                        t_eval=stops + [k + 0.5], events=(low, high))
        if sol.status == 1:
            status = "extinction" if sol.t_events[0].size else "blow-up"
            ended = float((sol.t_events[0] if sol.t_events[0].size else sol.t_events[1])[0])
            if j and sol.t.size and sol.t[0] == k:
                amps.append(float(sol.y[0, 0]))
            break
        if sol.status < 0:
            raise ContactLawError(f"the law's integration failed at contact {k}: {sol.message}")
        if j:
            amps.append(float(sol.y[0, 0]))
        half.append(float(sol.y[0, -1]))
        a = half[-1]
    return amps, half, status, ended


def _iterate_map(terms, ks, A0: float, n: float, death_fraction: float):
    """E_1 A_k^(n+1) = E_1 A_(k-1)^(n+1) + W(A_(k-1)), W the work of half of contact k - 1 and half of contact k:
    (A at ks, A at ks + 1/2 from the mean energy, status, end)."""
    amps: list = [A0]
    half: list = []
    for j in range(1, len(ks)):
        a = amps[-1]
        energy = a ** (n + 1) + (n + 1) * sum(0.5 * (r[j - 1] + r[j]) * a ** (q + n) for q, r in terms)
        if not energy > (death_fraction * A0) ** (n + 1):
            return amps, half, "extinction", float(ks[j])
        if energy > (A0 / death_fraction) ** (n + 1):
            return amps, half, "blow-up", float(ks[j])
        amps.append(energy ** (1 / (n + 1)))
        half.append((0.5 * (a ** (n + 1) + energy)) ** (1 / (n + 1)))
    return amps, half, "ok", None
