"""The map's bracketing fallback (map_bracket.py, Eq. 23): its vectorised grids against a point-by-point
scan of the same grids (the way it was done before, kept here as the reference)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from pulsemap.solvers.models import map_bracket
from pulsemap.solvers.models.codeload import map_module
from pulsemap.solvers.models.map_bracket import bisect, fallback, first_bracket


def scan(func, lo: float, hi: float, points: int) -> float | None:
    """First sign change of func on a log grid, point by point, refined by brentq (the reference)."""
    grid = np.geomspace(lo, hi, points)
    prev = None
    for a, b in zip(grid[:-1], grid[1:]):
        fa = func(a) if prev is None else prev
        fb = func(b)
        prev = fb
        if math.isfinite(fa) and math.isfinite(fb) and fa * fb <= 0:
            return brentq(func, a, b, xtol=1e-15 * b, rtol=1e-15, maxiter=200)
    return None


def reference(module, a_prev: float, eps: float, args: tuple, two: bool):
    (ilo, ihi, ipts), (olo, ohi, opts) = map_bracket.INNER, map_bracket.OUTER

    def next_of(a_i):
        root = scan(lambda c: module.map_residual(a_prev, a_i, c, eps, *args)[1], a_i * ilo, a_i * ihi, ipts)
        return math.nan if root is None else root

    def f1(a_i):
        if two:
            c = next_of(a_i)
            return math.nan if not math.isfinite(c) else module.map_residual(a_prev, a_i, c, eps, *args)[0]
        return module.map_residual(a_prev, a_i, eps, *args)[0]

    a_i = scan(f1, a_prev * olo, a_prev * ohi, opts)
    if a_i is None:
        return None
    return (a_i, next_of(a_i)) if two else (a_i,)


@pytest.mark.parametrize("variant", ["paper", "corrected", "1d"])
def test_fallback_finds_what_the_point_by_point_scan_finds(variant):
    """Random foundation R = -k u (Fig. 13's map, site-dependent k) and random states: the same roots
    to 1e-12, and None exactly where the scan finds none; both kinds occur."""
    mod = map_module("-k*u", ["k"], 1.5, "exact", variant, site_dependent=("k",))
    rng = np.random.default_rng(7)
    found = none = 0
    for _ in range(12):
        a_prev = 10 ** rng.uniform(-6, 0)  # small amplitudes: the foundation wins, no root
        args = tuple(rng.uniform(0, 1, len(mod.ARGS)))
        eps = float(rng.choice([-1.0, 1.0, 10.0]))
        two = variant != "1d"
        want = reference(mod, a_prev, eps, args, two)
        got = fallback(mod, a_prev, eps, args, two)
        if want is None:
            assert got is None
            none += 1
        else:
            assert got == pytest.approx(want, rel=1e-12)
            found += 1
    assert found and none


def test_van_der_pol_fallback_matches_the_scan():
    mod = map_module("-(u - mu*(1 - u^2)*v)", ["mu"], 1.5, "exact", "paper")
    for a_prev, mu in [(0.7, 3.0), (0.05, 1.0), (1.3, 2.0)]:
        want = reference(mod, a_prev, 0.1, (mu,), True)
        got = fallback(mod, a_prev, 0.1, (mu,), True)
        assert (want is None and got is None) or got == pytest.approx(want, rel=1e-12)


def test_first_bracket_skips_non_finite_ends_and_finds_zeros():
    v = np.array([[1.0, np.nan, -1.0, -2.0, 3.0],   # nan ends are skipped: first change at 3..4
                  [1.0, 0.0, -1.0, 2.0, 2.0],       # a zero closes the first interval
                  [1.0, 2.0, 3.0, np.inf, 4.0]])    # none
    assert first_bracket(v).tolist() == [3, 0, -1]


def test_bisect_reaches_round_off():
    lo, hi = np.array([1.0, 2.0, 0.1]), np.array([2.0, 3.0, 1.0])
    roots = bisect(lambda x: x**2 - np.array([2.0, 7.0, 0.25]), lo, hi)
    assert roots == pytest.approx(np.sqrt([2.0, 7.0, 0.25]), rel=4e-16)
