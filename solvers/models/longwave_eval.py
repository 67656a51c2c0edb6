"""The long-wave amplitude law (Eq. 30) evaluated along the chain.

A single power of B has a closed form (generated ``longwave_law``); several powers are solved as
the ODE dB/di = rhs(B) (equivalent to the quadrature of Eq. 31a): marched from contact to contact
by extrapolated midpoint steps (plain float arithmetic, no scipy), its end (extinction, B -> 0, or
blow-up) located by the quadrature itself; scipy's LSODA, with events for the end, where neither
settles (a stiff law, an end close to a contact). Contacts past the end of the law carry no value
(None), and the result says where and why the law ended, never a NaN.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import ModuleType
from typing import Callable

import numpy as np

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.models.map_iteration import contact_params


class LongwaveEvalError(PulsemapError):
    """The long-wave law cannot be evaluated for this scene."""


@dataclass(frozen=True)
class LawRun:
    contacts: np.ndarray
    A: list  # float, or None past the law's end
    peaks: list
    kind: str  # "power law", "exponential", "quadrature", "constant" (R does not force the contact)
    ended_at: float | None  # continuous contact index where A reached 0 or infinity
    ended: str  # "", "extinction", "blow-up"


def evaluate_law(module: ModuleType, A0: float, i0: float, contacts, eps: float, params) -> LawRun:
    """A(i) of Eq. 30 at ``contacts`` from A(i0) = A0."""
    if not getattr(module, "UNIFORM", False):
        raise LongwaveEvalError(
            "the long-wave law (Eq. 30) needs a uniform perturbation: drop 'longwave' from the methods"
        )
    contacts = np.asarray(contacts, dtype=float)
    if module.LAW_KIND is None:  # uniform, and no term of R forces contact i (e.g. R = 0): dB/di = 0
        return LawRun(contacts.astype(int), [float(A0)] * contacts.size, [float(A0) * module.S0] * contacts.size,
                      "constant", None, "")
    args = contact_params(module, params, int(i0) + 1)
    S0 = module.S0
    if hasattr(module, "longwave_law"):
        with np.errstate(over="ignore"):  # A past float64 is a blow-up, reported as such below
            A, base = module.longwave_law(contacts, A0, i0, eps, *args)
        A, base = np.broadcast_to(A, contacts.shape), np.broadcast_to(base, contacts.shape)
        ok = (base > 0) & np.isfinite(A)
        ended_at, ended = None, ""
        if np.all(base > 0) and not ok.all():  # the law's power left float64: blow-up at the first such contact
            ended_at, ended = float(contacts[np.argmin(ok)]), "blow-up"
        elif not ok.all():
            # base is linear in i: find where it crosses zero
            b0 = float(module.longwave_law(np.array([i0]), A0, i0, eps, *args)[1][0])
            b1 = float(module.longwave_law(np.array([i0 + 1.0]), A0, i0, eps, *args)[1][0])
            ended_at = i0 + b0 / (b0 - b1)
            # before the end the law is monotone: falling towards it is extinction, rising blow-up
            mid = float(module.longwave_law(np.array([(i0 + ended_at) / 2]), A0, i0, eps, *args)[0][0])
            ended = "extinction" if mid < A0 else "blow-up"
        vals = [float(a) if good else None for a, good in zip(A, ok)]
        return LawRun(contacts.astype(int), vals, [v * S0 if v is not None else None for v in vals],
                      module.LAW_KIND, ended_at, ended)
    # several powers: integrate dB/di
    law = solve_law(lambda B: module.longwave_rhs(B, eps, *args), A0, i0, contacts, module.P)
    return LawRun(contacts.astype(int), law.A, [v * S0 if v is not None else None for v in law.A],
                  "quadrature", law.ended_at, law.ended)


@dataclass(frozen=True)
class LawSolution:
    """A = B^(1/power) of dB/di = rhs(B) at each contact (None past the law's end), where and how the
    law ended, what solved it and, when the solver stopped short, its message."""

    A: list
    ended_at: float | None
    ended: str  # "", "extinction", "blow-up"
    solver: str
    failure: str | None


#: Relative agreement of successive extrapolations that ends a march step: the law's values to ~1e-13.
MARCH_RTOL = 1e-14
#: Substeps of the modified midpoint rule per march step (Bulirsch-Stoer's even sequence).
MIDPOINT_STEPS = (2, 4, 6, 8, 10, 12, 14, 16, 18, 20)
EPS = float(np.finfo(float).eps)
#: Smallest march step, in contacts: below it the law is too stiff or not smooth enough to march
#: (LSODA, a stiff solver, takes over).
MIN_MARCH_STEP = 2.0**-10
#: March steps allowed per contact of the law's span (and 256 more): past them LSODA takes over.
MARCH_STEPS_PER_CONTACT = 64
#: A march step changes B by at most this fraction (by its slope) and spans at most one time scale
#: 1/|d rhs/dB|: where the midpoint rule is stable and its extrapolation settles for real.
MAX_STEP_CHANGE = 0.2
#: The band B stays in (times B0): leaving it is the extinction or blow-up LSODA's events locate.
LAW_BAND = (1e-12, 1e12)


def solve_law(rhs: Callable[[float], float], A0: float, i0: float, contacts: np.ndarray, power: float) -> LawSolution:
    """dB/di = rhs(B), B = A^power, from A(i0) = A0 at ``contacts``: marched (:func:`march_law`) while
    B stays within LAW_BAND, the law's end where it leaves the band by the quadrature of Eq. 31a
    (:func:`law_end`) when no contact lies between the march's last step and that end; else LSODA
    (:func:`integrate_law`), which locates where the law ends with its events."""
    B0 = A0**power
    marched = march_law(rhs, B0, i0, contacts)
    if marched is not None:
        reached, i, B = marched
        values = [b ** (1.0 / power) for b in reached]
        solver = f"extrapolated midpoint, rtol {MARCH_RTOL:g}"
        if len(values) == len(contacts):
            return LawSolution(values, None, "", solver, None)
        end = law_end(rhs, i, B, LAW_BAND[0] * B0, LAW_BAND[1] * B0)
        if end is not None and float(contacts[len(values)]) > end[0] + 1e-12:
            return LawSolution(values + [None] * (len(contacts) - len(values)), *end,
                               solver + ", its end by quadrature", None)
    sol, ended_at, ended = integrate_law(rhs, B0, i0, contacts)
    return LawSolution(law_values(sol, contacts, power), ended_at, ended, "LSODA, rtol 1e-11",
                       sol.message if sol.status < 0 else None)


def march_law(rhs: Callable[[float], float], B0: float, i0: float,
              contacts: np.ndarray) -> tuple[list[float], float, float] | None:
    """(B at the contacts reached, and the contact index and B where the march stopped) of dB/di = rhs(B)
    from B(i0) = B0, stepped from contact to contact (ascending, >= i0; None otherwise) by extrapolated
    midpoint steps (Gragg-Bulirsch-Stoer), a step halved while its extrapolation does not settle and
    bounded by :func:`_step_bound`. It stops short of the last contact where B would leave LAW_BAND * B0
    (the law ends), a step falls below MIN_MARCH_STEP or the steps exceed MARCH_STEPS_PER_CONTACT."""
    lo, hi = LAW_BAND[0] * B0, LAW_BAND[1] * B0
    out: list[float] = []
    i, B = float(i0), float(B0)
    budget = MARCH_STEPS_PER_CONTACT * (float(max(contacts, default=i0)) - i) + 256
    if any(float(c) < i for c in contacts[:1]) or np.any(np.diff(np.asarray(contacts, dtype=float)) < 0):
        return None
    for c in (float(c) for c in contacts):
        while i < c:
            bound = _step_bound(rhs, B)
            budget -= 1
            if not bound >= MIN_MARCH_STEP or budget < 0:
                return out, i, B
            H = (c - i) / math.ceil((c - i) / bound)  # equal steps to the contact
            nxt = _extrapolated_step(rhs, B, H)
            while nxt is None and H >= 2 * MIN_MARCH_STEP:
                H *= 0.5
                nxt = _extrapolated_step(rhs, B, H)
            if nxt is None or not lo < nxt < hi:  # also NaN
                return out, i, B
            i, B = (c if H == c - i else i + H), nxt
        out.append(B)
    return out, i, B


def law_end(rhs: Callable[[float], float], i: float, B: float, lo: float, hi: float) -> tuple[float, str] | None:
    """(contact index, "extinction" or "blow-up") where dB/di = rhs(B) takes B from B at contact index i
    to lo or hi: i plus the quadrature of Eq. 31a, the integral of dB / rhs(B) = B / rhs(B) d(ln B), on
    Gauss-Legendre panels in ln B (smooth where B -> 0 as B^(3/5) does); None when rhs vanishes or
    changes sign on the way (the law does not end there) or two resolutions disagree beyond 1e-10."""
    slope = rhs(B)
    if not (math.isfinite(slope) and slope != 0.0):
        return None
    edge, how = (lo, "extinction") if slope < 0 else (hi, "blow-up")
    nodes, weights = np.polynomial.legendre.leggauss(8)

    def integral(panels: int) -> float | None:
        cuts = np.linspace(math.log(B), math.log(edge), panels + 1)
        half = 0.5 * np.diff(cuts)
        x = (0.5 * (cuts[:-1] + cuts[1:]))[:, None] + half[:, None] * nodes
        Bx = np.exp(x)
        r = np.array([[rhs(float(b)) for b in row] for row in Bx])
        if not np.all(np.isfinite(r)) or np.any(np.sign(r) != np.sign(slope)):
            return None
        return float(np.sum(half[:, None] * weights * Bx / r))

    coarse, fine = integral(32), integral(64)
    if coarse is None or fine is None or not abs(fine - coarse) <= 1e-10 * abs(fine):
        return None
    return i + fine, how


def _step_bound(rhs: Callable[[float], float], B: float) -> float:
    """The longest march step from B: MAX_STEP_CHANGE of B by the slope rhs(B), and one time scale
    1/|d rhs/dB| (a one-sided difference: only the scale matters)."""
    slope = rhs(B)
    dB = 1e-6 * B
    rate = abs((rhs(B + dB) - slope) / dB)
    return 1.0 / max(rate, abs(slope) / (MAX_STEP_CHANGE * B), 1e-300)


def _extrapolated_step(rhs: Callable[[float], float], B: float, H: float) -> float | None:
    """B after a step H: modified midpoint values with MIDPOINT_STEPS substeps extrapolated to zero step
    (Aitken-Neville in h^2) until two successive extrapolations agree to MARCH_RTOL, after at least three
    midpoint values and with the agreement improving (no chance agreement); None if they do not."""
    rows: list[list[float]] = []
    last_change = math.inf
    for k, n in enumerate(MIDPOINT_STEPS):
        h = H / n
        z0, z1 = B, B + h * rhs(B)
        for _ in range(n - 1):
            z0, z1 = z1, z0 + 2.0 * h * rhs(max(z1, 0.0))
        row = [0.5 * (z0 + z1 + h * rhs(max(z1, 0.0)))]
        for j in range(k):
            row.append(row[j] + (row[j] - rows[-1][j]) / ((n / MIDPOINT_STEPS[k - j - 1]) ** 2 - 1.0))
        change = abs(row[-1] - rows[-1][-1]) if k else math.inf
        improving = change < last_change or change <= 8 * EPS * abs(row[-1])  # or at rounding: a still law
        if k >= 2 and improving and change <= MARCH_RTOL * abs(row[-1]):
            return row[-1]
        rows.append(row)
        last_change = change
    return None


def integrate_law(rhs: Callable[[float], float], B0: float, i0: float, contacts: np.ndarray):
    """Solve dB/di = rhs(B) (B clipped at 0) from B(i0) = B0 past the last contact with LSODA (the
    quadrature of Eq. 31a, or of a balance law), stopping where B falls to 1e-12 B0 or grows to 1e12 B0.

    Returns (solution, ended_at, ended): where the law ended (None if it did not) and how
    ("extinction", "blow-up" or "").
    """

    def die(i, y):
        return y[0] - 1e-12 * B0

    def blow(i, y):
        return y[0] - 1e12 * B0

    die.terminal = blow.terminal = True
    end = float(contacts.max()) if contacts.size else i0
    from scipy.integrate import solve_ivp  # scipy loads only when a law is evaluated

    sol = solve_ivp(lambda i, y: [rhs(max(y[0], 0.0))], (i0, max(end, i0 + 1e-9)), [B0], method="LSODA",
                    rtol=1e-11, atol=1e-14 * B0, dense_output=True, events=(die, blow))
    ended_at, ended = None, ""
    if sol.status == 1:
        ended_at = float(sol.t[-1])
        ended = "extinction" if sol.t_events[0].size else "blow-up"
    return sol, ended_at, ended


def law_values(sol, contacts: np.ndarray, power: float) -> list:
    """A = B^(1/power) of ``integrate_law``'s solution at each contact; None past where it stopped."""
    stop = float(sol.t[-1])
    return [max(float(sol.sol(c)[0]), 0.0) ** (1.0 / power) if c <= stop + 1e-12 else None for c in contacts]
