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
    got = np.array(march_law(rhs, B0, I0, CONTACTS))
    np.testing.assert_allclose(got, exact(CONTACTS), rtol=1e-12, atol=0)


def test_march_matches_a_single_power_closed_form():
    """dB/di = -c B^p: B = (B0^(1-p) - (1-p) c t)^(1/(1-p)), p = 3/5 as the long-wave law's R = -mu v term."""
    c, p, B0 = 0.004, 0.6, 1.3
    got = np.array(march_law(lambda B: -c * B**p, B0, I0, CONTACTS))
    want = (B0 ** (1 - p) - (1 - p) * c * (CONTACTS - I0)) ** (1 / (1 - p))
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=0)


def test_march_agrees_with_lsoda_to_its_tolerance():
    rhs, _ = bernoulli(0.08, -0.05, 12 / 5, 0.9)
    sol, ended_at, ended = integrate_law(rhs, 0.9, I0, CONTACTS)
    lsoda = np.array(law_values(sol, CONTACTS, 1.0))
    np.testing.assert_allclose(march_law(rhs, 0.9, I0, CONTACTS), lsoda, rtol=1e-9)
    assert (ended_at, ended) == (None, "")


def test_a_law_that_ends_is_left_to_lsoda_which_locates_the_end():
    """dB/di = -c B^p reaches zero at t = B0^(1-p) / ((1-p) c): the march stops, LSODA reports extinction there."""
    c, p, B0 = 0.05, 0.6, 1.0
    rhs = lambda B: -c * max(B, 0.0) ** p  # noqa: E731
    assert march_law(rhs, B0, I0, CONTACTS) is None
    law = solve_law(rhs, B0, I0, CONTACTS, 1.0)
    end = I0 + B0 ** (1 - p) / ((1 - p) * c)
    assert law.ended == "extinction" and law.solver.startswith("LSODA")
    assert law.ended_at == pytest.approx(end, abs=0.05)
    assert all(v is None for v, i in zip(law.A, CONTACTS) if i > end + 0.05)
    assert all(v is not None and v > 0 for v, i in zip(law.A, CONTACTS) if i < end - 0.05)


def test_a_blow_up_is_left_to_lsoda():
    rhs, _ = bernoulli(0.0001, 0.02, 2.0, 1.0)  # dB/di ~ 0.02 B^2: infinite at t ~ 50
    law = solve_law(rhs, 1.0, I0, CONTACTS, 1.0)
    assert law.ended == "blow-up" and 60 < law.ended_at < 70


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
    assert march_law(rhs, 0.5, I0, CONTACTS) is None
    law = solve_law(rhs, 0.5, I0, CONTACTS, 1.0)
    assert law.solver.startswith("LSODA")
    np.testing.assert_allclose(law.A, exact(CONTACTS), rtol=1e-9)
