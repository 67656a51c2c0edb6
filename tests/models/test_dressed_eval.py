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
    run, beyond = evaluate_dressed_law(coef, 1.0, A0, i0, np.arange(16, 40))
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
    run, beyond = evaluate_dressed_law(coef, 1.0, 0.6, 15.0, np.arange(16, 200))
    assert run.status.startswith("outside its range") and run.A[-1] is None
    last = [a for a in run.A if a is not None][-1]
    assert abs(1.5 * -0.2 * last**-0.5) < 0.95
    assert beyond is None  # the validity bound (|x| = 1) lies past the pole (|x| = 0.95/1.5)
    # already outside at the seed: no value at all, said so
    coef = DressedCoefficients((-1.0,), (-0.5,), (-0.52,), (1.5,), (1.0,), (0.18,))
    run, _ = evaluate_dressed_law(coef, 1.0, 0.5, 15.0, np.arange(16, 20))
    assert all(a is None for a in run.A) and "at the seed" in run.message
    with pytest.raises(DressedEvalError, match="initial amplitude"):
        evaluate_dressed_law(coef, 1.0, -1.0, 15.0, [16])


def test_the_law_gives_no_values_past_its_validity_bound():
    """x = c A^(-1/2) with the bound |x| = 0.18 reached before the pole: the law stops there, said so."""
    coef = DressedCoefficients((-0.2,), (-0.5,), (-0.52,), (1.5,), (1.0,), (0.18,))
    run, beyond = evaluate_dressed_law(coef, 1.0, 2.0, 15.0, np.arange(16, 400))
    assert run.status == "beyond its validity bound" and run.ended_at == beyond and "\n" not in run.message
    values = [(c, a) for c, a in zip(run.contacts, run.A) if a is not None]
    assert values and all(c <= beyond for c, _ in values) and run.A[-1] is None
    assert abs(-0.2 * values[-1][1] ** -0.5) <= 0.18  # every value given lies inside the bound
    assert len(values) > 5 and beyond == pytest.approx(run.ended_at)
