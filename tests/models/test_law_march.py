"""The long-wave and balance laws' ODE dB/di = rhs(B) (paper Eq. 30/31a) marched without scipy
(solvers/models/longwave_eval.py: ``march_law``), against closed forms, and LSODA where the law ends."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pulsemap.solvers.models.longwave_eval import integrate_law, law_values, march_law, solve_law

CONTACTS = np.arange(16.0, 121.0)
I0 = 15.0


def bernoulli(a: float, b: float, q: float, B0: float):
    """dB/di = a B + b B^q and its closed form: B^(1-q) = (B0^(1-q) + b/a) e^((1-q) a t) - b/a."""
    def rhs(B: float) -> float:
        return a * B + b * B**q

    def exact(i: np.ndarray) -> np.ndarray:
        t = i - I0
        return ((B0 ** (1 - q) + b / a) * np.exp((1 - q) * a * t) - b / a) ** (1 / (1 - q))

    return rhs, exact


@pytest.mark.parametrize("a, b, q, B0", [
    (0.08, -0.05, 12 / 5, 0.9),   # growth saturating at the stationary amplitude (vdp-like, Eq. 41)
    (0.08, -0.05, 12 / 5, 3.0),   # decay onto it from above
    (-0.05, -0.02, 3.0, 2.0),     # decay towards zero without reaching it
    (2.0, -1.5, 2.0, 0.01),       # a fast logistic rise: the step bound, not the contact spacing, sets the steps
])
def test_march_matches_closed_forms_to_1e_12(a, b, q, B0):
    rhs, exact = bernoulli(a, b, q, B0)
    got, i, _ = march_law(rhs, B0, I0, CONTACTS)
    assert i == CONTACTS[-1]
    np.testing.assert_allclose(got, exact(CONTACTS), rtol=1e-12, atol=0)


def test_march_matches_a_single_power_closed_form():
    """dB/di = -c B^p: B = (B0^(1-p) - (1-p) c t)^(1/(1-p)), p = 3/5 as the long-wave law's R = -mu v term."""
    c, p, B0 = 0.004, 0.6, 1.3
    got = march_law(lambda B: -c * B**p, B0, I0, CONTACTS)[0]
    want = (B0 ** (1 - p) - (1 - p) * c * (CONTACTS - I0)) ** (1 / (1 - p))
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=0)


def test_march_agrees_with_lsoda_to_its_tolerance():
    rhs, _ = bernoulli(0.08, -0.05, 12 / 5, 0.9)
    sol, ended_at, ended = integrate_law(rhs, 0.9, I0, CONTACTS)
    lsoda = np.array(law_values(sol, CONTACTS, 1.0))
    np.testing.assert_allclose(march_law(rhs, 0.9, I0, CONTACTS)[0], lsoda, rtol=1e-9)
    assert (ended_at, ended) == (None, "")


def test_an_extinction_is_located_by_the_quadrature():
    """dB/di = -c B^p falls to the band's floor 1e-12 B0 at t = (B0^(1-p) - (1e-12 B0)^(1-p)) / ((1-p) c):
    the march stops short of it, Eq. 31a's quadrature locates it; LSODA's events agree to its tolerance."""
    c, p, B0 = 0.05, 0.6, 1.0
    rhs = lambda B: -c * max(B, 0.0) ** p  # noqa: E731
    law = solve_law(rhs, B0, I0, CONTACTS, 1.0)
    end = I0 + (B0 ** (1 - p) - (1e-12 * B0) ** (1 - p)) / ((1 - p) * c)
    assert law.ended == "extinction" and "quadrature" in law.solver
    assert law.ended_at == pytest.approx(end, rel=1e-10)
    assert integrate_law(rhs, B0, I0, CONTACTS)[1] == pytest.approx(end, rel=1e-6)
    live = CONTACTS < end
    assert all(v is None for v in np.array(law.A, dtype=object)[~live])
    np.testing.assert_allclose(np.array(law.A, dtype=object)[live].astype(float),
                               (B0 ** (1 - p) - (1 - p) * c * (CONTACTS[live] - I0)) ** (1 / (1 - p)), rtol=1e-11)


def test_a_blow_up_is_located_by_the_quadrature():
    a, b, B0 = 0.0001, 0.02, 1.0  # dB/di = a B + b B^2: 1/B = (1/B0 + b/a) e^(-a t) - b/a reaches 1e-12
    rhs, _ = bernoulli(a, b, 2.0, B0)
    law = solve_law(rhs, B0, I0, CONTACTS, 1.0)
    end = I0 - math.log((1e-12 / B0 + b / a) / (1 / B0 + b / a)) / a
    assert law.ended == "blow-up" and "quadrature" in law.solver
    assert law.ended_at == pytest.approx(end, rel=1e-10)


def test_contacts_before_the_start_are_not_marched():
    assert march_law(lambda B: -0.1 * B, 1.0, I0, np.array([14.0, 16.0])) is None


def test_solve_law_returns_amplitudes_a_equal_b_to_the_one_over_power():
    rhs, exact = bernoulli(0.08, -0.05, 12 / 5, 0.9)
    law = solve_law(rhs, 0.9 ** (1 / 1.25), I0, CONTACTS, 1.25)
    assert law.ended_at is None and law.failure is None and law.solver.startswith("extrapolated midpoint")
    np.testing.assert_allclose(law.A, exact(CONTACTS) ** (1 / 1.25), rtol=1e-12)
    assert math.isclose(law.A[0] ** 1.25, float(exact(np.array([16.0]))[0]), rel_tol=1e-12)


def test_a_stiff_law_is_left_to_lsoda():
    """A time scale far below a contact (d rhs/dB = -5000): no march, LSODA's stiff solution, which decays
    onto the stationary amplitude as the closed form does."""
    rhs, exact = bernoulli(5000.0, -5000.0, 2.0, 0.5)  # logistic onto B = 1 within a thousandth of a contact
    assert march_law(rhs, 0.5, I0, CONTACTS)[0] == []
    law = solve_law(rhs, 0.5, I0, CONTACTS, 1.0)
    assert law.solver.startswith("LSODA")
    np.testing.assert_allclose(law.A, exact(CONTACTS), rtol=1e-9)
