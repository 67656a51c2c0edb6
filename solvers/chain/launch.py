"""An exact solitary wave launched into the chain, and its leading-edge peaks (Eq. 1, Eqs. 4, 7).

``simulate`` (dns.py) starts from the paper's impulse (bead 1 given v0): the pulse that forms is
still settling at contact 15 (ln P_15 - ln P_inf ~ 2e-5 for n = 3/2), which swamps decrements of
order eps^2. Here the chain starts on the travelling wave itself,

    delta_j(0) = A S(c - j),  x_j = sum_{k >= j} delta_k,  x_j' = A^(1+s) sum_{k >= j} S'(c - k),

contact c at its peak at t = 0 (exact profile of Eq. 4, s = (n - 1)/2), so that without on-site
force every peak is A S(0) to the integrator's accuracy. c must exceed the profile's tail (the
wave must fit in the chain behind contact c; ``min_centre``). The whole chain is integrated with
DOP853 and dense output; the leading-edge peak of each contact is the maximum of delta_k(t) near
its predicted time, refined as the root of delta_k' = v_k - v_{k+1} on the dense output.

``Launch`` gives the same initial state to ``dns.simulate(Chain(..., launch=Launch(A, c)), ...)``, so either
engine (compiled or scipy), full chain or moving window, with its peak tracking and stop rules,
can run from the travelling wave: contacts
1..c have peaked by t = 0 and only contacts after c are tracked; the wave's velocity scale
A^((n+1)/2) plays the part of v0 in the thresholds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pulsemap.symbolic.profile import exact_profile
from pulsemap.solvers.chain.errors import DNSInputError
from pulsemap.solvers.chain.equations import OnSiteForce, make_rhs

#: A peak below this fraction of the launched peak A S(0) is round-off, not the pulse (``_peak``).
PEAK_FLOOR = 1e-8


@dataclass(frozen=True)
class LaunchResult:
    """Leading-edge peaks of contacts ``contacts`` of a launched soliton (None where not found)."""

    contacts: np.ndarray
    peaks: list
    times: list
    A: float
    centre: int
    rtol: float
    nfev: int


@dataclass(frozen=True)
class Launch:
    """Start ``dns.simulate`` from the exact solitary wave of scale ``amplitude`` (peak A S(0))
    with contact ``centre`` at its peak (``soliton_state``), instead of the impact v0 on bead 1."""

    amplitude: float
    centre: int

    def __post_init__(self) -> None:
        if not (isinstance(self.amplitude, (int, float)) and math.isfinite(self.amplitude) and self.amplitude > 0):
            raise DNSInputError(f"launch amplitude must be a finite number > 0, got {self.amplitude!r}")
        if isinstance(self.centre, bool) or not isinstance(self.centre, (int, np.integer)) or self.centre < 1:
            raise DNSInputError(f"launch centre must be an integer contact >= 1, got {self.centre!r}")

    def velocity_scale(self, exponent: float) -> float:
        """The wave's velocity scale A^((n+1)/2) (plays v0's part in thresholds and step sizes)."""
        return float(self.amplitude) ** ((exponent + 1.0) / 2.0)

    def front(self, exponent: float) -> int:
        """Last bead (1-based) the wave moves at t = 0 (beyond it: at rest to 1e-15 of the peak)."""
        return int(self.centre) + min_centre(exponent)

    def check(self, exponent: float, first_contact: int, beads: int) -> None:
        """One-line ValueErrors: the whole wave must fit on the chain and precede ``first_contact``."""
        lo = min_centre(exponent)
        if self.centre < lo:
            raise DNSInputError(f"launch centre {self.centre} must be >= {lo}: the wave's tail must fit on the chain "
                                 "behind it")
        if first_contact <= self.centre:
            raise DNSInputError(f"with a launch centred on contact {self.centre} the first tracked contact must come "
                                 f"after it, got {first_contact}")
        if self.front(exponent) + 1 > beads:
            raise DNSInputError(f"a launch centred on contact {self.centre} needs beads >= {self.front(exponent) + 1}, "
                                 f"got {beads}")

    def state(self, exponent: float, beads: int) -> np.ndarray:
        """The interleaved initial state of ``beads`` beads (soliton_state)."""
        return soliton_state(int(beads), float(exponent), float(self.amplitude), int(self.centre))


def min_centre(n: float = 1.5) -> int:
    """The smallest centre contact for which the launched wave fits in the chain (tail < 1e-15 S0)."""
    return int(math.ceil(exact_profile(float(n)).tail)) + 2


def soliton_state(beads: int, n: float, A: float, centre: int) -> np.ndarray:
    """Interleaved state [x_1, v_1, ...] of the travelling wave of scale A with contact ``centre`` at
    its peak (delta_j = A S(centre - j), Eq. 7 at t = 0)."""
    if isinstance(beads, bool) or not isinstance(beads, (int, np.integer)) or beads < 2:
        raise DNSInputError(f"beads must be an integer >= 2, got {beads!r}")
    if not (np.isfinite(A) and A > 0):
        raise DNSInputError(f"A must be a finite number > 0, got {A!r}")
    lo = min_centre(n)
    if not lo <= centre <= beads - lo:
        raise DNSInputError(f"centre must lie in [{lo}, beads - {lo}] = [{lo}, {beads - lo}] so the wave fits in the "
                             f"chain, got {centre!r}")
    prof = exact_profile(float(n))
    s = (float(n) - 1) / 2
    j = np.arange(1, beads)  # contacts 1..beads-1
    delta = A * prof.S(centre - j)
    ddelta = A ** (1 + s) * prof.dS(centre - j)  # d delta_j/dt = A^(1+s) S'(A^s t - j)
    x = np.zeros(beads)
    v = np.zeros(beads)
    x[:-1] = np.cumsum(delta[::-1])[::-1]  # x_j = sum_{k >= j} delta_k (the last bead at rest)
    v[:-1] = np.cumsum(ddelta[::-1])[::-1]
    y = np.empty(2 * beads)
    y[0::2], y[1::2] = x, v
    return y


def launch(beads: int, n: float, A: float, centre: int, contacts: tuple[int, int], force: OnSiteForce | None = None,
           *, rtol: float = 1e-11, atol: float = 1e-14) -> LaunchResult:
    """Integrate Eq. 1 from the launched wave until contact ``contacts[1]`` has peaked; return the peaks
    of contacts[0]..contacts[1] (each > centre). A peak is None where the pulse has died (below
    ``PEAK_FLOOR`` of the launched peak) or the maximum was not found (no NaN)."""
    first, last = int(contacts[0]), int(contacts[1])
    if not centre < first <= last <= beads - 2:
        raise DNSInputError(f"contacts {contacts!r} must satisfy centre < first <= last <= beads - 2")
    n = float(n)
    s = (n - 1) / 2
    y0 = soliton_state(beads, n, A, centre)
    rhs = make_rhs(beads, n, force)
    T = 1.5 * (last - centre + 2) / A**s  # generous: a decaying pulse slows down
    from scipy.integrate import solve_ivp  # scipy loads only when a wave is launched

    sol = solve_ivp(rhs, (0.0, T), y0, method="DOP853", rtol=rtol, atol=atol, dense_output=True)
    T = float(sol.t[-1])  # where the integration stopped (a failed step ends it early: later peaks are None)
    peaks: list = []
    times: list = []
    t_prev, gap = 0.0, 1.0 / A**s
    floor = PEAK_FLOOR * A * exact_profile(n).S0
    for k in range(first, last + 1):
        p, tk = _peak(sol, k, t_prev, min(T, t_prev + 4 * gap), floor)
        if p is None and t_prev + 4 * gap < T:
            p, tk = _peak(sol, k, t_prev, T, floor)
        peaks.append(p)
        times.append(tk)
        if p is None:
            peaks += [None] * (last - k)
            times += [None] * (last - k)
            break
        if k > first:
            gap = tk - t_prev
        t_prev = tk
    return LaunchResult(np.arange(first, last + 1), peaks, times, float(A), int(centre), float(rtol), int(sol.nfev))


def _peak(sol, k: int, t_from: float, T: float, floor: float) -> tuple[float | None, float | None]:
    """The first maximum of delta_k(t) above ``floor`` after t_from (contact k, 1-based), on the dense
    output. The floor keeps round-off ahead of the wave out: an anti-damping force (+c v) amplifies a
    1e-16 wobble of a bead at rest into a local maximum that is not the pulse."""
    ts = np.linspace(t_from, T, max(100, int(40 * (T - t_from))))
    Y = sol.sol(ts)
    d = Y[2 * (k - 1)] - Y[2 * k]
    dv = Y[2 * (k - 1) + 1] - Y[2 * k + 1]
    idx = np.nonzero((dv[:-1] > 0) & (dv[1:] <= 0) & (d[:-1] > floor))[0]
    if idx.size == 0:
        return None, None
    a, b = ts[idx[0]], ts[idx[0] + 1]

    def rate(t):
        y = sol.sol(t)
        return y[2 * (k - 1) + 1] - y[2 * k + 1]

    from scipy.optimize import brentq

    tk = brentq(rate, a, b, xtol=1e-14, rtol=1e-15) if rate(b) != 0 else b
    y = sol.sol(tk)
    value = float(y[2 * (k - 1)] - y[2 * k])
    return (value, float(tk)) if np.isfinite(value) and value > 0 else (None, None)
