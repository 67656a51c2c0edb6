"""The amplitude map's bracketing fallback (Eq. 23) for a contact where Newton fails.

    F1(A_{i-1}, A_i, A_{i+1}) = 0,   F2(A_i, A_{i+1}) = 0                               (Eq. 23)

A_{i+1}(A_i) is the first root of F2 on a log grid in A_{i+1} from A_i 1e-6 to A_i 1e3 (INNER
points); A_i the first root of f1(A_i) = F1(A_{i-1}, A_i, A_{i+1}(A_i)) on a log grid from
A_{i-1} 1e-9 to A_{i-1} 1e2 (OUTER points); a root is refined by brentq in the first grid interval
whose ends are finite and of opposite sign (variant 1d: F1 in A_i alone). Each grid is evaluated in
one numpy call of the generated residual, the inner one for every outer point at once, its roots
refined by vectorised bisection to round-off for the outer scan; the outer root found is then
refined point by point with brentq. The brackets and roots are those of a scan point by point.
"""

from __future__ import annotations

import math
from types import ModuleType

import numpy as np

Array = np.ndarray
INNER = (1e-6, 1e3, 200)  # A_{i+1} / A_i: grid ends and points
OUTER = (1e-9, 1e2, 600)  # A_i / A_{i-1}
BISECTIONS = 64  # halvings of a grid interval (ratio <= 1.11): below round-off


def first_bracket(values: Array) -> Array:
    """Per row, the index k of the first interval [k, k+1] whose ends are finite and of opposite
    sign (or zero); -1 where there is none. ``values``: (..., points)."""
    fa, fb = values[..., :-1], values[..., 1:]
    with np.errstate(invalid="ignore", over="ignore"):
        ok = np.isfinite(fa) & np.isfinite(fb) & (fa * fb <= 0)
    return np.where(ok.any(axis=-1), ok.argmax(axis=-1), -1)


def refine(func, a: float, b: float) -> float:
    """brentq on a bracket (the tolerances of the reference scan)."""
    from scipy.optimize import brentq  # scipy loads only when a fallback runs

    return brentq(func, a, b, xtol=1e-15 * b, rtol=1e-15, maxiter=200)


def bisect(func, lo: Array, hi: Array) -> Array:
    """Roots of the vectorised ``func`` in brackets [lo, hi] (elementwise), by BISECTIONS halvings."""
    lo, hi = lo.copy(), hi.copy()
    with np.errstate(all="ignore"):
        flo = func(lo)
        for _ in range(BISECTIONS):
            mid = 0.5 * (lo + hi)
            fm = func(mid)
            left = np.sign(fm) == np.sign(flo)
            lo, flo = np.where(left, mid, lo), np.where(left, fm, flo)
            hi = np.where(left, hi, mid)
            zero = fm == 0
            lo, hi = np.where(zero, mid, lo), np.where(zero, mid, hi)
    return 0.5 * (lo + hi)


def _grid(start, stop, points: int) -> Array:
    with np.errstate(all="ignore"):
        return np.geomspace(start, stop, points, axis=-1)


def _scan(values: Array, grid: Array, func) -> float | None:
    """The first root of ``func`` on ``grid`` from its values there, refined by brentq."""
    k = int(first_bracket(values))
    return None if k < 0 else refine(func, float(grid[k]), float(grid[k + 1]))


def next_amplitude(module: ModuleType, a_prev: float, a_i: float, eps: float, args: tuple) -> float:
    """A_{i+1}(A_i): the first root of F2 on the inner grid (NaN if none)."""
    def f2(c):
        return module.map_residual(a_prev, a_i, c, eps, *args)[1]

    grid = _grid(a_i * INNER[0], a_i * INNER[1], INNER[2])
    with np.errstate(all="ignore"):
        root = _scan(np.asarray(f2(grid), dtype=float), grid, f2)
    return math.nan if root is None else root


def _outer_values(module: ModuleType, a_prev: float, grid: Array, eps: float, args: tuple, two: bool) -> Array:
    """f1 on the outer grid, all points at once (the inner roots by bisection)."""
    with np.errstate(all="ignore"):
        if not two:
            return np.asarray(module.map_residual(a_prev, grid, eps, *args)[0], dtype=float) * np.ones_like(grid)
        inner = _grid(grid * INNER[0], grid * INNER[1], INNER[2])  # (OUTER points, INNER points)
        a_i = grid[:, None]
        f2 = np.asarray(module.map_residual(a_prev, a_i, inner, eps, *args)[1], dtype=float) * np.ones_like(inner)
        k = first_bracket(f2)
        has = k >= 0
        rows = np.flatnonzero(has)
        c = np.full(grid.shape, np.nan)
        if rows.size:
            lo, hi = inner[rows, k[rows]], inner[rows, k[rows] + 1]
            c[rows] = bisect(lambda x: module.map_residual(a_prev, grid[rows], x, eps, *args)[1], lo, hi)
        return np.asarray(module.map_residual(a_prev, grid, c, eps, *args)[0], dtype=float) * np.ones_like(grid)


def fallback(module: ModuleType, a_prev: float, eps: float, args: tuple, two: bool) -> tuple[float, ...] | None:
    """(A_i, A_{i+1}) (or (A_i,)) by bracketing, None when the grids hold no positive root."""
    def f1(a_i: float) -> float:
        if two:
            c = next_amplitude(module, a_prev, a_i, eps, args)
            if not math.isfinite(c):
                return math.nan
            return module.map_residual(a_prev, a_i, c, eps, *args)[0]
        return module.map_residual(a_prev, a_i, eps, *args)[0]

    grid = _grid(a_prev * OUTER[0], a_prev * OUTER[1], OUTER[2])
    a_i = _scan(_outer_values(module, a_prev, grid, eps, args, two), grid, f1)
    if a_i is None:
        return None
    return (a_i, next_amplitude(module, a_prev, a_i, eps, args)) if two else (a_i,)
