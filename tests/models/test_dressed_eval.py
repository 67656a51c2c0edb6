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


def test_the_law_marks_its_validity_bound_and_gives_values_past_it():
    """x = c A^(-1/2) with the bound |x| = 0.18 reached before the pole: ``beyond`` marks where, and the law goes
    on (the cut is its estimated error's, not the bound's)."""
    coef = DressedCoefficients((-0.2,), (-0.5,), (-0.52,), (1.5,), (1.0,), (0.18,))
    ev = evaluate_dressed_law(coef, 1.0, 2.0, 15.0, np.arange(16, 400))
    assert ev.beyond is not None and 16 < ev.beyond < 400
    at = [a for c, a in zip(ev.run.contacts, ev.run.A) if a is not None and c > ev.beyond]
    assert at and abs(-0.2 * at[0] ** -0.5) > 0.18  # past the bound indeed, and given


# A gain (c v, e = -1/4) against a loss (c' u^2 v, e = 7/4): a stable fixed point A*, the Van der Pol balance.
GAIN_LOSS = dict(c=(0.03, -0.03), e=(-0.25, 1.75), k1=(-4 / 9, -0.9967), rho=(0.29, 2.23), lag=(0.27, 0.96),
                 x_bound=(math.inf, math.inf), cross=((0, 1, -0.6),), next_coef=(0.08, 8.0), next_power=(2.0, 2.0))


def test_slope_is_the_derivative_of_the_rate():
    coef = DressedCoefficients(**GAIN_LOSS)
    for A in (0.3, 0.7, 1.2):
        h = 1e-6
        fd = (coef.rate(A * math.exp(h)) - coef.rate(A * math.exp(-h))) / (2 * h)
        assert coef.slope(A) == pytest.approx(fd, rel=1e-7)


def _measured(coef, A0, i0, residual, offset=0.0, span=12, miss=0.0):
    """A MeasuredError whose seed segment is the law itself moved by ``miss`` in ln A, with one residual
    everywhere (two nodes spanning every amplitude)."""
    from pulsemap.solvers.models.dressed import MeasuredError

    path = evaluate_dressed_law(coef, 1.0, A0, i0, np.arange(i0 + 1, i0 + span + 1))
    lnA = tuple(math.log(a) + miss for a in path.run.A)
    return MeasuredError(tuple(float(c) for c in path.run.contacts), lnA, 1e-10, (-50.0, 50.0),
                         (residual, residual), offset)


def test_error_estimate_is_the_fixed_point_shift_of_a_measured_residual():
    """At a stable fixed point the carried error settles on the larger shift of ln A* that a rate error of
    either sign and the measured size causes (the root of the rate with it added, brentq): the bound follows the
    rate's secant, not its tangent; on the seed segment the estimate is the measured miss plus the segments'
    accuracy."""
    from scipy.optimize import brentq

    coef = DressedCoefficients(**GAIN_LOSS)
    star = brentq(coef.rate, 0.2, 2.0)
    r = 2e-4
    measured = _measured(coef, star, 15.0, r, miss=0.003)
    ev = evaluate_dressed_law(coef, 1.0, star, 15.0, np.arange(16, 400), measured)
    assert ev.run.A[-1] == pytest.approx(star, rel=1e-6)
    assert ev.accuracy[0] == pytest.approx(math.expm1(0.003 + 1e-10), rel=1e-6)
    moved = max(abs(math.log(brentq(lambda A: coef.rate(A) + q, 0.2, 2.0) / star)) for q in (r, -r))
    assert math.log1p(ev.accuracy[-1]) == pytest.approx(moved, rel=1e-3)  # the seed's miss has relaxed by 400
    assert moved > r / abs(coef.slope(star))  # the tangent alone would understate it
    # the offset adds to the residual as a rate error; nothing measured: no estimate, every value given
    halves = _measured(coef, star, 15.0, r / 2, r / 2, miss=0.003)
    both = evaluate_dressed_law(coef, 1.0, star, 15.0, np.arange(16, 400), halves)
    assert both.accuracy[-1] == pytest.approx(ev.accuracy[-1], rel=1e-9)
    bare = evaluate_dressed_law(coef, 1.0, star, 15.0, np.arange(16, 400))
    assert all(a is None for a in bare.accuracy) and all(a is not None for a in bare.run.A)


def test_residual_bound_is_the_larger_neighbour():
    from pulsemap.solvers.models.dressed import MeasuredError

    m = MeasuredError((16.0,), (0.0,), 0.0, (0.0, -0.1, -0.3), (1e-4, 3e-4, 2e-4), 0.0)
    assert m.residual_bound(-0.05) == 3e-4 and m.residual_bound(-0.2) == 3e-4
    assert m.residual_bound(0.2) == 1e-4 and m.residual_bound(-0.5) == 2e-4


def test_the_law_is_quiet_where_its_estimated_error_passes_its_accuracy():
    """A large measured residual: the estimate passes ACCURACY, no value there, one line saying why; every value
    given carries an estimate within ACCURACY; a lost launched pulse (residual inf) gives no value past it, nor does
    a chain whose pulse died in the seed segment, and nothing measured gives no value at all."""
    from pulsemap.solvers.models.dressed import ACCURACY, MeasuredError

    coef = DressedCoefficients(**GAIN_LOSS)
    ev = evaluate_dressed_law(coef, 1.0, 0.35, 15.0, np.arange(16, 300), _measured(coef, 0.35, 15.0, 2e-3))
    assert ev.run.status == "beyond its accuracy" and "\n" not in ev.run.message and "5 %" in ev.run.message
    quiet = [c for c, a in zip(ev.run.contacts, ev.run.A) if a is None]
    assert quiet and ev.run.A[0] is not None  # quiet only where the estimate has grown
    assert all(e is not None and e <= ACCURACY for a, e in zip(ev.run.A, ev.accuracy) if a is not None)
    assert all(e is None for a, e in zip(ev.run.A, ev.accuracy) if a is None)
    lost = evaluate_dressed_law(coef, 1.0, 0.35, 15.0, np.arange(16, 60), _measured(coef, 0.35, 15.0, math.inf))
    assert [c for c, a in zip(lost.run.contacts, lost.run.A) if a is not None] == list(range(16, 28))
    # the chain's pulse died within the seed segment (an inf residual past it), or before it: no value past it
    short = _measured(coef, 0.35, 15.0, 0.0, span=5)
    dead = MeasuredError(short.contacts, short.lnA, short.tol, (short.lnA[-1],), (math.inf,), math.inf)
    ev = evaluate_dressed_law(coef, 1.0, 0.35, 15.0, np.arange(16, 60), dead)
    assert [c for c, a in zip(ev.run.contacts, ev.run.A) if a is not None] == list(range(16, 21))
    none = MeasuredError((), (), 1e-8, (), (), math.inf)
    assert all(a is None for a in evaluate_dressed_law(coef, 1.0, 0.35, 15.0, np.arange(16, 60), none).run.A)
