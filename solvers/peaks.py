"""Leading-edge peak extraction for the DNS of paper Eq. 1.

The primary-pulse amplitude on contact i is the first local maximum in time of the strain
delta_i(t) = x_i - x_{i+1} that exceeds a fraction of the previous contact's peak. A maximum is
found where delta_i' = v_i - v_{i+1} changes sign from + to - over an integrator step and located
by a root of delta_i' on the step's dense output (brentq), so its accuracy is the integrator's,
not a sampling grid's. The state is interleaved: y = [x_1, v_1, x_2, v_2, ...].
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.optimize import brentq

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


def first_threshold(velocity: float, exponent: float, fraction: float) -> float:
    """Threshold for contact 1: fraction of the v0 scale v0^(2/(n+1)) (homogeneity of Eq. 1)."""
    return fraction * velocity ** (2.0 / (exponent + 1.0))


def is_falling_crossing(rate_old: float, rate_new: float) -> bool:
    """True when delta' goes from + to - (or 0) over a step: a maximum lies inside."""
    return rate_old > 0.0 and rate_new <= 0.0


def locate_maximum(dense: DenseOutput, t_old: float, t_new: float, k: int) -> tuple[float, float]:
    """Time and value of the maximum of delta_k inside [t_old, t_new] (root of delta_k').

    The dense output is the integrator's own interpolant, so the root is as accurate as the
    step. If the interpolant does not bracket the root (it agrees with the step ends only to
    round-off) the larger end value is returned.
    """

    def rate(t: float) -> float:
        return strain_rate(dense(t), k)

    fa, fb = rate(t_old), rate(t_new)
    if fa > 0.0 and fb <= 0.0:
        if fb == 0.0:
            t_peak = t_new
        else:
            t_peak = brentq(rate, t_old, t_new, xtol=1e-15, rtol=4 * np.finfo(float).eps)
    else:
        t_peak = t_old if strain(dense(t_old), k) >= strain(dense(t_new), k) else t_new
    return float(t_peak), strain(dense(t_peak), k)


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
