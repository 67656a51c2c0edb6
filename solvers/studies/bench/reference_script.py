"""The careful user's script: the reference every speed ratio of the compiled DNS is quoted against.

Paper Eq. 1 on the full chain, written the way a careful numpy user writes it,

    x_i'' = (x_{i-1} - x_i)_+^n - (x_i - x_{i+1})_+^n + F_i(x_i, x_i'),

with a vectorised right-hand side, ``solve_ivp(method="DOP853", t_eval=<grid>, dense_output=True)``,
and each contact's leading-edge peak taken as the first grid maximum of delta_k = x_k - x_{k+1}
above 1e-2 of the previous contact's peak (the first one above 1e-2 v0^(2/(n+1))), then refined
by brentq on delta_k' of the dense output. No moving window, no step-by-step peak tracking:
pulsemap's own DNS must beat this at equal accuracy (``pulsemap bench``, benchmarks/bench_compiled.py).
Unlike baseline (a) of studies/bench/baselines.py (a loop RHS, peaks read off the grid) it is accurate
to its tolerance.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from pulsemap.solvers.chain.peaks import velocity_scale

__all__ = ["GRID_STEP", "ScriptResult", "script_peaks"]

GRID_STEP = 0.05
"""Sampling step of the script's grid, in units of the contact time (1 / contact_rate(v0, n))."""


@dataclass(frozen=True)
class ScriptResult:
    """Peaks of contacts first..last (NaN where none was found), the integrator's cost and the wall time."""

    contacts: np.ndarray
    peaks: np.ndarray
    nfev: int
    wall_time_s: float


def script_peaks(beads: int, n: float, v0: float, contacts: tuple[int, int], force, rtol: float, t_end: float,
                 dt: float) -> ScriptResult:
    """Run the script (module docstring) to ``t_end`` with grid step ``dt``; ``force`` an OnSiteForce or None
    (its vectorised ``force(x, v)``), atol = rtol / 100."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import brentq

    first, last = contacts
    f_on = None if force is None else force.force
    t0 = time.perf_counter()

    def rhs(t, y):
        x, v = y[:beads], y[beads:]
        d = np.maximum(x[:-1] - x[1:], 0.0) ** n
        a = np.zeros(beads)
        a[:-1] -= d
        a[1:] += d
        if f_on is not None:
            a += f_on(x, v)
        return np.concatenate([v, a])

    y0 = np.zeros(2 * beads)
    y0[beads] = v0
    grid = np.arange(0.0, t_end, dt)
    sol = solve_ivp(rhs, (0.0, grid[-1]), y0, method="DOP853", t_eval=grid, rtol=rtol, atol=rtol * 1e-2,
                    dense_output=True)
    xs = sol.y[: last + 1]
    peaks = np.full(last, np.nan)
    threshold, t_floor = 1e-2 * velocity_scale(v0, n), 0.0
    for k in range(1, last + 1):
        d = xs[k - 1] - xs[k]
        ok = (d[1:-1] > d[:-2]) & (d[1:-1] >= d[2:]) & (d[1:-1] > threshold) & (grid[1:-1] >= t_floor)
        idx = np.flatnonzero(ok)
        if not idx.size:
            break
        j = idx[0] + 1

        def rate(t, k=k):
            s = sol.sol(t)
            return s[beads + k - 1] - s[beads + k]

        a, b = grid[j - 1], grid[j + 1]
        t_pk = brentq(rate, a, b, xtol=1e-14) if rate(a) > 0 > rate(b) else grid[j]
        s = sol.sol(t_pk)
        peaks[k - 1] = s[k - 1] - s[k]
        threshold, t_floor = 1e-2 * peaks[k - 1], t_pk
    return ScriptResult(np.arange(first, last + 1), peaks[first - 1:], int(sol.nfev), time.perf_counter() - t0)
