"""Baselines for honest speed ratios of the DNS of paper Eq. 1.

(a) ``baseline_script``: the script a careful user would write today. A Python ``for`` loop
    over the beads computes Eq. 1 inside the right-hand side,

        x_i'' = (x_{i-1} - x_i)_+^n - (x_i - x_{i+1})_+^n + F_i(x_i, x_i'),

    ``scipy.integrate.solve_ivp(method="RK45", t_eval=<uniform grid>)`` integrates the whole
    chain, and each contact's peak is read off the sampled grid: the first local maximum of
    delta_i = x_i - x_{i+1} on the grid above 1e-2 of the previous contact's peak. No
    vectorisation (that is the point), otherwise solve_ivp's normal interface.
(b) the full-chain vectorised DNS: ``pulsemap.solvers.chain.dns.simulate`` with ``window=None``.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.integrate import solve_ivp

from pulsemap.solvers.chain.peaks import contact_rate, velocity_scale


@dataclass(frozen=True)
class BaselineResult:
    """Peaks of contacts[0]..contacts[1] (1-based) read off the sampled grid, and the cost."""

    contacts: np.ndarray
    peaks: np.ndarray
    peak_times: np.ndarray
    alive: np.ndarray
    wall_time_s: float
    nfev: int
    method: str
    rtol: float
    atol: float
    dt_sample: float
    beads: int


def script_rhs(beads: int, exponent: float, force_py: Callable[[int, float, float], float] | None):
    """Eq. 1 the way a user writes it: y = [x_1..x_N, v_1..v_N], a loop over beads.

    ``force_py(i, x_i, v_i)`` (i 1-based) is the on-site force F_i, eps included.
    """
    n = exponent

    def rhs(t, y):
        x = y[:beads]
        v = y[beads:]
        dydt = np.zeros(2 * beads)
        for i in range(beads):
            acc = 0.0
            if i > 0 and x[i - 1] > x[i]:
                acc += (x[i - 1] - x[i]) ** n
            if i < beads - 1 and x[i] > x[i + 1]:
                acc -= (x[i] - x[i + 1]) ** n
            if force_py is not None:
                acc += force_py(i + 1, x[i], v[i])
            dydt[i] = v[i]
            dydt[beads + i] = acc
        return dydt

    return rhs


def first_maximum(d: np.ndarray, times: np.ndarray, threshold: float, t_floor: float) -> int | None:
    """Index of the first interior local maximum of d above ``threshold`` at or after ``t_floor``."""
    inner = (d[1:-1] > d[:-2]) & (d[1:-1] >= d[2:]) & (d[1:-1] > threshold) & (times[1:-1] >= t_floor)
    idx = np.flatnonzero(inner)
    return None if len(idx) == 0 else int(idx[0]) + 1


def baseline_script(
    beads: int,
    exponent: float,
    velocity: float,
    contacts: tuple[int, int],
    force_py: Callable[[int, float, float], float] | None = None,
    *,
    rtol: float = 1e-8,
    atol: float = 1e-10,
    dt_sample: float = 0.01,
    t_end: float | None = None,
    segment_samples: int | None = None,
) -> BaselineResult:
    """Baseline (a): loop RHS + solve_ivp(RK45, t_eval grid) + peaks on the grid.

    ``t_end`` defaults to the unperturbed arrival time at the last contact plus a few contact
    times (the formed wave at n = 1.5 takes 1.19 v0^(-(n-1)/(n+1)) per contact: t_end =
    (5 + 1.25 last) / rate), as short as a user who knows the wave speed would make it; pass
    ``t_end`` for a damped (slower) pulse. ``segment_samples``: integrate in consecutive
    solve_ivp calls of that many grid samples each and read the peaks as the samples come (what a
    user does when the 2N x samples grid would not fit in memory, e.g. N = 1000); the grid and
    the peaks are the same as in one call (None: one call over the whole grid).
    """
    first, last = int(contacts[0]), int(contacts[1])
    if t_end is None:
        t_end = (5.0 + 1.25 * last) / contact_rate(velocity, exponent)
    grid = np.arange(0.0, t_end + 0.5 * dt_sample, dt_sample)
    y0 = np.zeros(2 * beads)
    y0[beads] = velocity
    rhs = script_rhs(beads, exponent, force_py)
    thr = 1e-2 * velocity_scale(velocity, exponent)
    segment = len(grid) if segment_samples is None else int(segment_samples)
    wall0 = _time.perf_counter()
    peaks, when = np.full(last, np.nan), np.full(last, np.nan)
    k, threshold, t_floor, nfev = 0, thr, -np.inf, 0
    tail_x, tail_t, y, start = None, None, y0, 0
    while start < len(grid) - 1 and k < last:
        stop = min(len(grid), start + segment)
        sol = solve_ivp(rhs, (grid[start], grid[stop - 1]), y, method="RK45", t_eval=grid[start:stop],
                        rtol=rtol, atol=atol)
        nfev += int(sol.nfev)
        x, t = sol.y[:beads], sol.t
        if tail_x is not None:  # the sample before this segment, for maxima on its first sample
            x, t = np.hstack([tail_x, x]), np.concatenate([tail_t, t])
        while k < last:
            j = first_maximum(x[k] - x[k + 1], t, threshold, t_floor)
            if j is None:
                break
            peaks[k], when[k] = x[k, j] - x[k + 1, j], t[j]
            threshold, t_floor, k = 1e-2 * peaks[k], t[j], k + 1
        tail_x, tail_t, y, start = x[:, -2:-1], t[-2:-1], sol.y[:, -1], stop - 1
    wall = _time.perf_counter() - wall0
    sel = slice(first - 1, last)
    return BaselineResult(
        contacts=np.arange(first, last + 1), peaks=peaks[sel], peak_times=when[sel],
        alive=np.isfinite(peaks[sel]), wall_time_s=wall, nfev=nfev, method="RK45",
        rtol=float(rtol), atol=float(atol), dt_sample=float(dt_sample), beads=int(beads))


def script_force(scene, beads: int) -> Callable[[int, float, float], float]:
    """The scene's on-site force eps_i R_i(x, v) as baseline (a) calls it: one bead at a time.

    A user would type R as a Python expression; this evaluates the scene's generated force
    module on scalars (same arithmetic, per-bead parameter values picked by index), 0 before
    first_perturbed.
    """
    from pulsemap.solvers.models.codeload import force_module
    from pulsemap.solvers.studies.scene_chain import parameter_values

    pert = scene.perturbation
    mod = force_module(pert.text, pert.used_parameters)
    prm = parameter_values(scene, beads)  # scalars, or arrays over the beads for site-dependent parameters
    columns = [np.broadcast_to(np.asarray(prm[name], float), beads) for name in mod.PARAMS]
    per_bead = [tuple(float(c[i]) for c in columns) for i in range(beads)]
    eps, first = float(pert.eps), int(scene.first_perturbed)

    def force_py(i: int, x: float, v: float) -> float:
        if i < first:
            return 0.0
        return float(mod.force(x, v, float(i), eps, *per_bead[i - 1]))

    return force_py
