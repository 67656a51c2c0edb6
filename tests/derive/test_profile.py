"""Exact solitary wave (Eq. 4) and its Pade form (Eq. 5)."""

import numpy as np
import pytest

from pulsemap.symbolic.profile import (
    ProfileError,
    exact_profile,
    get_profile,
    pade_profile,
)


def equation4_residual(profile, tau: np.ndarray) -> np.ndarray:
    """S''(tau) - [S(tau-1)^n - 2 S(tau)^n + S(tau+1)^n], relative to S(0), at any tau (Eq. 4)."""
    n = profile.n
    pos = lambda x: np.maximum(profile.S(x), 0.0) ** n  # noqa: E731
    return (profile.d2S(tau) - (pos(tau - 1) - 2 * pos(tau) + pos(tau + 1))) / profile.S0


@pytest.mark.parametrize("n", [1.5, 2.5, 1.2])
def test_residual_of_eq4_at_nodes_and_between(n):
    p = exact_profile(n)
    assert p.residual < 1e-9
    # Off the grid: S'' of the interpolant against Eq. 4 evaluated with the interpolant.
    tau = np.linspace(-4.0, 4.0, 1601) + 0.001234
    assert np.max(np.abs(equation4_residual(p, tau))) < 1e-9


@pytest.mark.parametrize("n", [1.5, 3.0])
def test_second_derivative_independent_of_eq4(n):
    """S'' by a 5-point stencil on S itself equals the right-hand side of Eq. 4."""
    p = exact_profile(n)
    tau = np.linspace(-3.0, 3.0, 301) + 0.00377
    h = 4e-3
    fd = (-p.S(tau + 2 * h) + 16 * p.S(tau + h) - 30 * p.S(tau) + 16 * p.S(tau - h) - p.S(tau - 2 * h)) / (12 * h * h)
    pos = lambda x: np.maximum(p.S(x), 0) ** n  # noqa: E731
    rhs = pos(tau - 1) - 2 * pos(tau) + pos(tau + 1)
    assert np.max(np.abs(fd - rhs)) / p.S0 < 1e-7


def test_profile_is_even_peaked_and_positive():
    p = exact_profile(1.5)
    tau = np.linspace(0.01, 6, 500)
    assert np.allclose(p.S(tau), p.S(-tau), rtol=0, atol=1e-14)
    assert abs(float(p.dS(0.0))) < 1e-12
    assert np.all(np.diff(p.S(tau)) <= 1e-15)  # decreasing away from the peak
    assert float(p.S(0.0)) == pytest.approx(p.S0, rel=1e-14)
    assert p.S0 > float(np.max(p.S(tau)))


def test_derivative_matches_finite_difference():
    p = exact_profile(1.5)
    tau = np.linspace(-4, 4, 401) + 0.0031
    h = 1e-3
    fd = (-p.S(tau + 2 * h) + 8 * p.S(tau + h) - 8 * p.S(tau - h) + p.S(tau - 2 * h)) / (12 * h)
    assert np.max(np.abs(fd - p.dS(tau))) < 1e-10


@pytest.mark.parametrize("n", [1.5, 2.0])
def test_scaling_law_of_the_travelling_wave(n):
    """A S(A^s t) solves y'' = y(t-T)^n - 2 y^n + y(t+T)^n with T = A^(-s), s = (n-1)/2."""
    p = exact_profile(n)
    s = (n - 1) / 2
    for amp in (0.37, 5.0):
        delay = amp**-s
        t = np.linspace(-3 * delay, 3 * delay, 401) + 0.0017
        y = lambda x: amp * p.S(amp**s * x)  # noqa: E731
        ypp = amp ** (1 + 2 * s) * p.d2S(amp**s * t)
        rhs = y(t - delay) ** n - 2 * y(t) ** n + y(t + delay) ** n
        assert np.max(np.abs(ypp - rhs)) / amp**n < 1e-9
        # and the wrong delay does not: the check can fail
        wrong = y(t - 1.1 * delay) ** n - 2 * y(t) ** n + y(t + 1.1 * delay) ** n
        assert np.max(np.abs(ypp - wrong)) / amp**n > 1e-3


def test_homogeneity_fixes_s0_and_grid_does_not_matter():
    """S(0) is a property of n alone: it does not depend on the initial guess or tolerance."""
    a = exact_profile(1.5)
    b = exact_profile(1.5, tol=1e-13)
    assert a.S0 == pytest.approx(b.S0, rel=1e-11)
    assert exact_profile(3.0).S0 != pytest.approx(a.S0, rel=1e-3)


def test_pade_agrees_with_exact_to_its_reported_error():
    exact = exact_profile(1.5)
    pade = pade_profile(1.5)
    assert pade.q[0] == pytest.approx(exact.S0**-0.5, rel=1e-14)
    assert all(q > 0 for q in pade.q)
    assert pade.accuracy < 5e-3
    tau = np.linspace(-8, 8, 3201) + 0.0007
    dev = np.max(np.abs(pade.S(tau) - exact.S(tau))) / exact.S0
    assert dev <= pade.accuracy * 1.05
    assert dev > 0.2 * pade.accuracy  # the reported error is not a loose bound
    # Pade decays algebraically (erratum 9, docs/errata.rst): far tails are larger than the exact ones.
    assert float(pade.S(8.0)) > 1e3 * max(float(exact.S(8.0)), 1e-300)


def test_pade_derivatives_consistent():
    pade = pade_profile(1.5)
    t = np.linspace(-5, 5, 201) + 0.013
    h = 1e-4
    assert np.max(np.abs((pade.S(t + h) - pade.S(t - h)) / (2 * h) - pade.dS(t))) < 1e-7
    assert np.max(np.abs((pade.dS(t + h) - pade.dS(t - h)) / (2 * h) - pade.d2S(t))) < 1e-6


@pytest.mark.parametrize("bad", [1.0, 0.5, -2, float("nan"), float("inf"), "abc", True])
def test_bad_exponent_is_a_clear_error(bad):
    with pytest.raises(ProfileError, match="exponent n"):
        get_profile("exact", bad)


def test_unknown_profile_name():
    with pytest.raises(ProfileError, match="unknown profile 'spline'.*exact, pade"):
        get_profile("spline", 1.5)


def test_near_one_the_profile_is_wide_and_still_solves_eq4():
    """n = 1.05 needs a grid longer than 8192 nodes (tail ~ 15): the blocked inner product keeps it fast."""
    p = exact_profile(1.05)
    assert p.residual < 1e-9 and p.tail > 12.0
    tau = np.linspace(-10.0, 10.0, 2001) + 0.0031
    assert np.max(np.abs(equation4_residual(p, tau))) < 1e-9
    # wider than the Hertz wave (width ~ (n - 1)^(-1/2))
    assert p.half_width > 1.5 * exact_profile(1.5).half_width


def test_blocked_inner_product_is_np_dot_for_one_block():
    from pulsemap.symbolic.profile import _dot

    rng = np.random.default_rng(3)
    a, b = rng.normal(size=8192), rng.normal(size=8192)
    assert _dot(a, b) == float(np.dot(a, b))
    a, b = rng.normal(size=3 * 8192 + 5), rng.normal(size=3 * 8192 + 5)
    assert _dot(a, b) == pytest.approx(float(np.dot(a, b)), rel=1e-12)


@pytest.mark.parametrize("n", [1.0000001, 1.009])
def test_exponent_too_close_to_one_states_the_bound(n):
    with pytest.raises(ProfileError, match=r"n = 1\.0.* is too close to 1: supported 1\.01 <= n <= 20"):
        get_profile("exact", n)
