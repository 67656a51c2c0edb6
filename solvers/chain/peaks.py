"""Leading-edge peak extraction for the DNS of paper Eq. 1.

The primary-pulse amplitude on contact i is the first local maximum in time of the strain
delta_i(t) = x_i - x_{i+1} that exceeds a fraction of the previous contact's peak. A maximum is
found where delta_i' = v_i - v_{i+1} changes sign from + to - over an integrator step and located
by a root of delta_i' on the step's dense output (brentq), so its accuracy is the integrator's,
not a sampling grid's. The state is interleaved: y = [x_1, v_1, x_2, v_2, ...].
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Callable

import numpy as np

from pulsemap.solvers.chain.errors import DNSInputError
from pulsemap.solvers.chain import methods

DenseOutput = Callable[[float], np.ndarray]


@dataclass(frozen=True)
class Peak:
    """A located maximum of delta_k (k 1-based contact index)."""

    contact: int
    time: float
    value: float


def strain(y: np.ndarray, k: int) -> float:
    """delta_k = x_k - x_{k+1} from the interleaved state (k 1-based)."""
    return float(y[2 * k - 2] - y[2 * k])


def strain_rate(y: np.ndarray, k: int) -> float:
    """delta_k' = v_k - v_{k+1} from the interleaved state (k 1-based)."""
    return float(y[2 * k - 1] - y[2 * k + 1])


def velocity_scale(velocity: float, exponent: float) -> float:
    """Strain scale v0^(2/(n+1)) set by homogeneity of Eq. 1."""
    return velocity ** (2.0 / (exponent + 1.0))


def contact_rate(velocity: float, exponent: float) -> float:
    """Contact frequency ~ A^s, s = (n-1)/2, with A = velocity_scale: v0^((n-1)/(n+1))."""
    return velocity ** ((exponent - 1.0) / (exponent + 1.0))


def first_threshold(velocity: float, exponent: float, fraction: float) -> float:
    """Threshold for contact 1: fraction of the v0 scale v0^(2/(n+1)) (homogeneity of Eq. 1)."""
    return fraction * velocity_scale(velocity, exponent)


def is_falling_crossing(rate_old: float, rate_new: float) -> bool:
    """True when delta' goes from + to - (or 0) over a step: a maximum lies inside."""
    return rate_old > 0.0 and rate_new <= 0.0


def locate_maximum(dense: DenseOutput, t_old: float, t_new: float, k: int) -> tuple[float, float]:
    """Time and value of the maximum of delta_k inside [t_old, t_new] (root of delta_k').

    The dense output is the integrator's own interpolant, so the root is as accurate as the
    step. If the interpolant does not bracket the root (it agrees with the step ends only to
    round-off) the larger end value is returned. A ``QuinticStep`` interpolant only locates the
    root; the value is then taken from its exact re-step to that time (see QuinticStep).
    """
    if isinstance(dense, QuinticStep):
        return dense.maximum(k)

    def rate(t: float) -> float:
        return strain_rate(dense(t), k)

    fa, fb = rate(t_old), rate(t_new)
    if fa > 0.0 and fb <= 0.0:
        if fb == 0.0:
            t_peak = t_new
        else:
            from scipy.optimize import brentq  # scipy loads only when a scipy engine runs

            t_peak = brentq(rate, t_old, t_new, xtol=1e-15, rtol=4 * np.finfo(float).eps)
    else:
        t_peak = t_old if strain(dense(t_old), k) >= strain(dense(t_new), k) else t_new
    return float(t_peak), strain(dense(t_peak), k)


ExactStep = Callable[[float, np.ndarray, np.ndarray, float], np.ndarray]


class QuinticStep:
    """One accepted step seen through a quintic Hermite interpolant, with an exact re-step.

    For an engine without dense output (Hairer's Fortran codes). The strain delta_k(t) is
    interpolated from delta, delta' and delta'' (accelerations of Eq. 1) at both ends of the
    step; that locates the root t* of delta_k' to ~h^5. The peak value is then read off the
    state at t* obtained by ``exact_step`` (one step of the integrator's own scheme from the
    nearer end of the step, so at most half a step long and at least as accurate as the
    accepted one), with a Newton correction delta - delta'^2 / (2 delta'') for the residual
    offset of t*. Cost: two right-hand-side evaluations for the ends plus one re-step per peak.
    """

    def __init__(self, t0: float, y0: np.ndarray, f0: np.ndarray, t1: float, y1: np.ndarray,
                 f1: np.ndarray, exact_step: ExactStep) -> None:
        self.t0, self.t1, self.h = t0, t1, t1 - t0
        self.ends = ((t0, y0, f0), (t1, y1, f1))
        self.exact_step = exact_step
        self.evaluations = 0
        h = self.h
        # positions: p(s) = sum c_j s^j, s = (t - t0)/h, with p, p', p'' matching at s = 0, 1
        c0, c1, c2 = y0[0::2], h * y0[1::2], 0.5 * h * h * f0[1::2]
        r0 = y1[0::2] - (c0 + c1 + c2)
        r1 = h * y1[1::2] - (c1 + 2.0 * c2)
        r2 = h * h * f1[1::2] - 2.0 * c2
        self.coef = (c0, c1, c2, 10.0 * r0 - 4.0 * r1 + 0.5 * r2,
                     -15.0 * r0 + 7.0 * r1 - r2, 6.0 * r0 - 3.0 * r1 + 0.5 * r2)

    def _strain_coef(self, k: int) -> list[float]:
        return [float(c[k - 1] - c[k]) for c in self.coef]

    def __call__(self, t: float) -> np.ndarray:
        """Interpolated state (positions and velocities) at t."""
        s = (t - self.t0) / self.h
        c0, c1, c2, c3, c4, c5 = self.coef
        out = np.empty(2 * len(c0))
        out[0::2] = c0 + s * (c1 + s * (c2 + s * (c3 + s * (c4 + s * c5))))
        out[1::2] = (c1 + s * (2.0 * c2 + s * (3.0 * c3 + s * (4.0 * c4 + s * 5.0 * c5)))) / self.h
        return out

    def exact(self, t: float) -> np.ndarray:
        """State at t from one step of the integrator's scheme from the nearer end."""
        (ta, ya, fa), (tb, yb, fb) = self.ends
        self.evaluations += 1
        if t - ta <= tb - t:
            return self.exact_step(ta, ya, fa, t - ta)
        return self.exact_step(tb, yb, fb, t - tb)

    def maximum(self, k: int) -> tuple[float, float]:
        """(time, value) of the maximum of delta_k in the step (see the class docstring)."""
        c = self._strain_coef(k)
        h = self.h

        def rate(s: float) -> float:
            return c[1] + s * (2.0 * c[2] + s * (3.0 * c[3] + s * (4.0 * c[4] + s * 5.0 * c[5])))

        def accel(s: float) -> float:
            return (2.0 * c[2] + s * (6.0 * c[3] + s * (12.0 * c[4] + s * 20.0 * c[5]))) / (h * h)

        ra, rb = rate(0.0), rate(1.0)
        if ra > 0.0 and rb < 0.0:
            from scipy.optimize import brentq

            s_peak = brentq(rate, 0.0, 1.0, xtol=1e-15, rtol=4 * np.finfo(float).eps)
        else:  # the ends' rates are those of the step up to round-off: the maximum is an end
            s_peak = 0.0 if ra <= 0.0 else 1.0
        t_peak = self.t0 + s_peak * h
        y = self.exact(t_peak)
        value, d_rate, d_acc = strain(y, k), strain_rate(y, k), accel(s_peak)
        if d_acc < 0.0 and abs(d_rate / d_acc) < abs(h):
            return float(t_peak - d_rate / d_acc), float(value - 0.5 * d_rate * d_rate / d_acc)
        return float(t_peak), float(value)


def scan_step(
    y_old: np.ndarray,
    y_new: np.ndarray,
    t_old: float,
    t_new: float,
    dense_factory: Callable[[], DenseOutput],
    next_contact: int,
    last_contact: int,
    threshold: float,
    fraction: float,
) -> list[Peak]:
    """Leading-edge peaks completed during one step, in contact order.

    ``next_contact`` is the first contact without a peak, ``threshold`` its acceptance level
    (fraction of the previous peak). A maximum below the threshold is pre-arrival round-off
    and is skipped. After a peak is accepted the following contact is examined within the same
    step with threshold ``fraction * peak``. ``dense_factory`` is called at most once.
    """
    found: list[Peak] = []
    dense: DenseOutput | None = None
    k = next_contact
    t_floor = t_old
    while k <= last_contact:
        if not is_falling_crossing(strain_rate(y_old, k), strain_rate(y_new, k)):
            break
        if dense is None:
            dense = dense_factory()
        t_peak, value = locate_maximum(dense, t_old, t_new, k)
        if not value > threshold or t_peak < t_floor:
            break
        found.append(Peak(k, t_peak, value))
        threshold = fraction * value
        t_floor = t_peak
        k += 1
    return found


def primary_pulse_lost(peaks: np.ndarray, k: int, first: int, death_fraction: float,
                       overtake_factor: float, times: np.ndarray | None = None,
                       delay_factor: float = 2.0) -> str:
    """Why contact k no longer carries the primary pulse ("" while it does).

    The pulse has died when its peak falls below ``death_fraction`` times the peak at contact
    ``first``. An O(eps) perturbation changes the pulse little from one contact to the next, so
    a jump means contact k's first maximum is something else: a peak above ``overtake_factor``
    times contact k-1's (the wake, or a self-excited wave, arrived first), or a delay since
    contact k-1 above ``delay_factor`` times the delay before it (the front no longer travels
    as a solitary wave, e.g. a slow compression left by strong damping).
    """
    if k < first:
        return ""
    value = peaks[k - 1]
    if value < death_fraction * peaks[first - 1]:
        return f"peak below {death_fraction:g} x peak at contact {first}"
    if k > first and value > overtake_factor * peaks[k - 2]:
        return (f"the wake overtook the front: peak jumped {value / peaks[k - 2]:.3g}x from contact "
                f"{k - 1}, above the {overtake_factor:g}x an eps-small perturbation allows")
    if times is not None and k >= 3 and k - 2 >= first:
        before, now = times[k - 2] - times[k - 3], times[k - 1] - times[k - 2]
        if before > 0 and now > delay_factor * before:
            return (f"the front stopped travelling as a solitary wave: delay {now:.3g} after contact "
                    f"{k - 1}, over {delay_factor:g}x the {before:.3g} before it")
    return ""


# ----------------------------------------------------------------------------- run bookkeeping


def budget_advice(method: str) -> str:
    """What to try when the step budget runs out: an implicit method, unless one is already in use (the
    scipy engine's or the compiled Rodas4, which Coulomb friction runs: chain/methods.py)."""
    if method in methods.names(implicit=True):
        return f"{method} is already an implicit method: raise max_steps or ask for fewer contacts"
    return f"too stiff for the method? try method='{methods.auto_pick('scipy stiff')}'"


@dataclass(frozen=True)
class StopRules:
    """When a DNS run stops before its last contact peaks, and what counts as a peak (PeakTracker):
    a contact's first maximum counts above ``peak_fraction`` x the previous contact's peak; the pulse
    has died below ``death_fraction`` x the first requested contact's peak, been overtaken by its wake
    above ``overtake_factor`` x the previous peak, stalled when no contact peaks within
    ``stall_factor`` x the last inter-peak delay; ``t_max`` and ``max_steps`` (accepted steps) bound
    the run (None: dns.simulate's defaults, equations.default_t_max and default_max_steps)."""

    peak_fraction: float = 1e-2
    death_fraction: float = 1e-3
    overtake_factor: float = 1.25
    stall_factor: float = 5.0
    t_max: float | None = None
    max_steps: int | None = None

    def __post_init__(self) -> None:
        """Refuse every value no run can use: one-line TypeError/ValueError naming the field and its range."""
        for name in ("peak_fraction", "death_fraction", "stall_factor", "overtake_factor"):
            real_number(getattr(self, name), name)
        if self.t_max is not None:
            real_number(self.t_max, "t_max")
        if not 0.0 < self.peak_fraction < 1.0:
            raise DNSInputError(f"peak_fraction must lie in (0, 1), got {self.peak_fraction!r}")
        if not 0.0 <= self.death_fraction < 1.0:
            raise DNSInputError(f"death_fraction must lie in [0, 1), got {self.death_fraction!r}")
        if self.t_max is not None and not (math.isfinite(self.t_max) and self.t_max > 0.0):
            raise DNSInputError(f"t_max must be a finite number > 0 or None, got {self.t_max!r}")
        if not (math.isfinite(self.stall_factor) and self.stall_factor > 1.0):
            raise DNSInputError(f"stall_factor must be a finite number > 1, got {self.stall_factor!r}")
        if not (math.isfinite(self.overtake_factor) and self.overtake_factor > 1.0):
            raise DNSInputError(f"overtake_factor must be a finite number > 1, got {self.overtake_factor!r}")
        steps = self.max_steps
        if steps is not None and (isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1):
            raise DNSInputError(f"max_steps must be an integer >= 1 or None, got {steps!r}")


def real_number(value, name: str) -> None:
    """A TypeError naming ``name`` unless ``value`` is a real number (not a bool, not a string), a
    ValueError when it is an integer beyond float64."""
    if isinstance(value, bool) or not isinstance(value, (numbers.Real, np.floating, np.integer)):
        raise TypeError(f"{name} must be a number, got {type(value).__name__} {value!r}"[:200])
    try:
        float(value)
    except OverflowError:
        raise DNSInputError(f"{name} is beyond the float range (an integer of {len(str(value))} digits)") from None


@dataclass
class PeakTracker:
    """Peaks found so far and the stop rules of one DNS run (full chain or moving window).

    Mutable bookkeeping shared by solvers/dns.py and solvers/window.py, so both stop for the
    same reasons with the same messages: the last contact peaked, the pulse died (peak below
    ``death_fraction`` x the first requested contact's, see ``primary_pulse_lost``), the pulse
    stopped advancing (no new peak within ``stall_factor`` x the last inter-peak delay), t_max,
    a step budget, or a blow-up (non-finite state, energy beyond ``ENERGY_BLOWUP`` x initial).
    """

    first: int
    last: int
    peak_fraction: float
    death_fraction: float
    overtake_factor: float
    stall_factor: float
    peaks: np.ndarray
    times: np.ndarray
    threshold: float
    stall: float
    next_contact: int = 1
    last_peak_time: float = 0.0
    died_at: int | None = None
    reason: str = ""
    blew_up: bool = False
    steps: int = 0
    method: str = ""  # the integrator, for the advice when the step budget runs out

    @classmethod
    def start(cls, first: int, last: int, velocity: float, exponent: float, stop: StopRules, *,
              next_contact: int = 1, method: str = "") -> "PeakTracker":
        """Tracker at t = 0 under ``stop``; the first stall window is stall_factor contact times (~A^-s).

        ``next_contact``: the first contact still to peak (1 for an impact on bead 1; past the
        centre of a launched solitary wave, solvers/chain/launch.py)."""
        return cls(first, last, stop.peak_fraction, stop.death_fraction, stop.overtake_factor, stop.stall_factor,
                   np.full(last, np.nan), np.full(last, np.nan),
                   first_threshold(velocity, exponent, stop.peak_fraction),
                   stop.stall_factor / contact_rate(velocity, exponent), next_contact=int(next_contact),
                   method=str(method))

    def record(self, found: list[Peak], offset: int = 0) -> None:
        """Store peaks found in one step (contacts relative to ``offset``); stop at a lost pulse."""
        for peak in found:
            k = peak.contact + offset
            self.peaks[k - 1], self.times[k - 1] = peak.value, peak.time
            self.stall = self.stall_factor * (peak.time - self.last_peak_time)
            self.last_peak_time = peak.time
            self.threshold = self.peak_fraction * peak.value
            self.next_contact = k + 1
            why = primary_pulse_lost(self.peaks, k, self.first, self.death_fraction,
                                     self.overtake_factor, self.times)
            if why:
                self.died_at = k
                self.reason = f"pulse died at contact {k} ({why})"
                return

    def check_progress(self, t: float, t_max: float, max_steps: int) -> str:
        """After a step: the stop reason from contacts, stall, t_max or step budget ("" to go on)."""
        self.steps += 1
        if self.reason:
            return self.reason
        if self.next_contact > self.last:
            self.reason = "last contact peaked"
        elif t - self.last_peak_time > self.stall:
            nc = self.next_contact
            after = f"after contact {nc - 1}" if nc > 1 else "before contact 1"
            self.reason = (f"pulse died: stopped advancing {after} (no peak within {self.stall:.4g} time"
                           f" units, t={t:.6g})")
        elif t >= t_max:
            self.reason = f"t_max reached (t={t:.6g}, next contact {self.next_contact})"
        elif self.steps >= max_steps:
            self.reason = (f"step budget of {max_steps} steps used up at t={t:.6g} before contact "
                           f"{self.next_contact} ({budget_advice(self.method)})")
        return self.reason

    def check_state(self, t: float, e: float, e0: float, limit: float) -> str:
        """Blow-up guard: a non-finite state/energy or energy beyond ``limit`` x initial."""
        if not np.isfinite(e):
            self.reason = f"blow-up: the state became non-finite at t={t:.6g}"
        elif not e <= limit * e0:
            self.reason = (f"blow-up: energy grew beyond {limit:g} x its initial value at t={t:.6g}"
                           f" (unstable perturbation?); peaks up to contact {self.next_contact - 1} kept")
        else:
            return ""
        self.blew_up = True
        return self.reason

    def outcome(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(contacts, peaks, peak times, alive) of the requested range first..last."""
        alive = np.isfinite(self.peaks)
        if self.died_at is not None:
            alive[self.died_at - 1 :] = False
        sel = slice(self.first - 1, self.last)
        return (np.arange(self.first, self.last + 1), self.peaks[sel].copy(), self.times[sel].copy(),
                alive[sel].copy())
