"""The dressed law's evaluator (sympy-free) against derive's closed form; where it stops."""

import math

import numpy as np
import pytest
import sympy

from pulsemap.symbolic.dressed import A, A_S, I0, DressedLaw, DressedTerm
from pulsemap.solvers.models.dressed import DressedCoefficients, DressedEvalError, evaluate_dressed_law


def _term(c, e, k1, rho, lag):
    return DressedTerm("m", (0, 1), c, sympy.nsimplify(e), k1, "", rho, 0.0, "", lag, 0.0, "", "x^2", 0.0)


@pytest.mark.parametrize("c, e, k1, rho, lag", [(-0.1, -0.25, -4 / 9, 0.29, 0.27), (-0.05, 1.5, -1.92, 20.0, 1.75),
                                                (-0.1, -0.5, -0.52, 1.5, 1.05)])
def test_evaluator_matches_the_closed_form(c, e, k1, rho, lag):
    law = DressedLaw(1.5, (_term(c, e, k1, rho, lag),))
    coef = DressedCoefficients((c,), (e,), (k1,), (rho,), (lag,), (math.inf,))
    A0, i0 = 0.6, 15.0
    ev = evaluate_dressed_law(coef, 1.0, A0, i0, np.arange(16, 40))
    run, beyond = ev.run, ev.beyond
    A_s = A0 * math.exp(law.onset_shift(A0))
    imp = law.implicit()
    for contact, amp in zip(run.contacts, run.A):
        if amp is None:
            break
        assert float(imp.xreplace({A: amp, A_S: A_s, I0: i0})) == pytest.approx(float(contact), abs=1e-7)
    assert beyond is None


def test_the_law_stops_where_the_second_order_term_reaches_the_first():
    # x = c A^(-1/2) grows as A decays: |rho x| reaches 0.95 at A = (0.95 / (rho |c|))^-2
    coef = DressedCoefficients((-0.2,), (-0.5,), (-0.52,), (1.5,), (1.0,), (1.0,))
    ev = evaluate_dressed_law(coef, 1.0, 0.6, 15.0, np.arange(16, 200))
    run, beyond = ev.run, ev.beyond
    assert run.status.startswith("outside its range") and run.A[-1] is None
    last = [a for a in run.A if a is not None][-1]
    assert abs(1.5 * -0.2 * last**-0.5) < 0.95
    assert beyond is None  # the validity bound (|x| = 1) lies past the pole (|x| = 0.95/1.5)
    # already outside at the seed: no value at all, said so
    coef = DressedCoefficients((-1.0,), (-0.5,), (-0.52,), (1.5,), (1.0,), (0.18,))
    run = evaluate_dressed_law(coef, 1.0, 0.5, 15.0, np.arange(16, 20)).run
    assert all(a is None for a in run.A) and "at the seed" in run.message
    with pytest.raises(DressedEvalError, match="initial amplitude"):
        evaluate_dressed_law(coef, 1.0, -1.0, 15.0, [16])


def test_the_law_gives_no_values_past_its_validity_bound():
    """x = c A^(-1/2) with the bound |x| = 0.18 reached before the pole: the law stops there, said so."""
    coef = DressedCoefficients((-0.2,), (-0.5,), (-0.52,), (1.5,), (1.0,), (0.18,))
    ev = evaluate_dressed_law(coef, 1.0, 2.0, 15.0, np.arange(16, 400))
    run, beyond = ev.run, ev.beyond
    assert run.status == "beyond its validity bound" and run.ended_at == beyond and "\n" not in run.message
    values = [(c, a) for c, a in zip(run.contacts, run.A) if a is not None]
    assert values and all(c <= beyond for c, _ in values) and run.A[-1] is None
    assert abs(-0.2 * values[-1][1] ** -0.5) <= 0.18  # every value given lies inside the bound
    assert len(values) > 5 and beyond == pytest.approx(run.ended_at)


# A gain (c v, e = -1/4) against a loss (c' u^2 v, e = 7/4): a stable fixed point A*, the Van der Pol balance.
GAIN_LOSS = dict(c=(0.03, -0.03), e=(-0.25, 1.75), k1=(-4 / 9, -0.9967), rho=(0.29, 2.23), lag=(0.27, 0.96),
                 x_bound=(math.inf, math.inf), cross=((0, 1, -0.6),), next_coef=(0.08, 8.0), next_power=(2.0, 2.0))


def test_slope_is_the_derivative_of_the_rate():
    coef = DressedCoefficients(**GAIN_LOSS)
    for A in (0.3, 0.7, 1.2):
        h = 1e-6
        fd = (coef.rate(A * math.exp(h)) - coef.rate(A * math.exp(-h))) / (2 * h)
        assert coef.slope(A) == pytest.approx(fd, rel=1e-7)


def test_error_estimate_is_the_fixed_point_shift_of_the_neglected_terms():
    """At a stable fixed point the estimate settles on neglected/|slope|: SAFETY times the shift of ln A* that
    the neglected terms cause, checked against the root of the rate with them added (brentq)."""
    from scipy.optimize import brentq

    from pulsemap.solvers.models.dressed import ONSET_RATIO, SAFETY

    coef = DressedCoefficients(**GAIN_LOSS)
    star = brentq(coef.rate, 0.2, 2.0)
    ev = evaluate_dressed_law(coef, 1.0, star, 15.0, np.arange(16, 400))
    assert ev.run.A[-1] == pytest.approx(star, rel=1e-6)
    settled = coef.neglected(star) / abs(coef.slope(star))
    assert ev.accuracy[-1] == pytest.approx(settled, rel=1e-4)  # relaxed onto it by contact 400
    moved = brentq(lambda A: coef.rate(A) + coef.neglected(A) / SAFETY, 0.2, 2.0)
    assert SAFETY * abs(math.log(moved / star)) == pytest.approx(settled, rel=0.05)  # linearisation
    # the onset's uncertainty (the whole onset shift) relaxes by ONSET_RATIO per contact
    E0 = coef.shift_error(star)
    assert E0 > 5 * settled and E0 * ONSET_RATIO <= ev.accuracy[0] <= E0 * ONSET_RATIO + 2 * coef.neglected(star)


def test_the_law_is_quiet_where_its_estimated_error_passes_its_accuracy():
    """A hundred times the neglected terms: the estimate passes ACCURACY, no value there, one line saying why; every
    value given carries an estimate within ACCURACY."""
    from pulsemap.solvers.models.dressed import ACCURACY

    big = {**GAIN_LOSS, "next_coef": (8.0, 800.0)}
    coef = DressedCoefficients(**big)
    ev = evaluate_dressed_law(coef, 1.0, 0.35, 15.0, np.arange(16, 300))
    assert ev.run.status == "beyond its accuracy" and "\n" not in ev.run.message and "5 %" in ev.run.message
    quiet = [c for c, a in zip(ev.run.contacts, ev.run.A) if a is None]
    assert quiet and ev.run.A[0] is not None  # quiet only where the estimate has grown
    assert all(e is not None and e <= ACCURACY for a, e in zip(ev.run.A, ev.accuracy) if a is not None)
    assert all(e is None for a, e in zip(ev.run.A, ev.accuracy) if a is None)
