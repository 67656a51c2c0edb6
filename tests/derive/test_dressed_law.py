"""The dressed law (derive/dressed.py) substituted back into its ODE; its onset shift and validity bound."""

import math

import pytest
import sympy

from pulsemap.symbolic.dressed import A, A_S, I0, CrossTerm, DressedLaw, DressedTerm


def _term(c=-0.1, e=sympy.Rational(-1, 4), k1=-4 / 9, rho=0.29, lag=0.27, next_kind="x^2", nxt=0.08, name="v"):
    return DressedTerm(name, (0, 1), c, e, k1, "derived", rho, 1e-6, "calibrated", lag, 1e-5, "calibrated",
                       next_kind, nxt)


@pytest.mark.parametrize("e", [sympy.Rational(-1, 4), sympy.Rational(-1, 2), sympy.Rational(3, 2), sympy.Integer(0)])
def test_closed_form_solves_the_ode(e):
    law = DressedLaw(1.5, (_term(e=e, c=-0.05),))
    for amp in (0.9, 0.3, 0.05):
        assert abs(law.residual(amp)) < 1e-12
    # and starts at A_s
    imp = law.implicit()
    assert float(imp.xreplace({A: 0.7, A_S: 0.7, I0: 15})) == pytest.approx(15, abs=1e-12)


def test_rate_is_the_pade_of_the_two_term_series():
    t = _term()
    law = DressedLaw(1.5, (t,))
    for amp in (1.0, 0.2):
        x = t.c * amp ** float(t.e)
        assert law.rate_value(amp) == pytest.approx(-t.k1 * x / (1 - t.rho * x), rel=1e-14)
        assert float(law.rate(A).subs(A, amp)) == pytest.approx(law.rate_value(amp), rel=1e-14)
        # expanded: -k1 x - k2 x^2 + O(x^3)
        assert law.rate_value(amp) == pytest.approx(-t.k1 * x - t.k2 * x * x, abs=abs(t.k1 * t.rho**2 * x**3) * 1.01)


def test_onset_shift_and_cross_terms():
    u = _term(name="u", c=-0.1, e=sympy.Rational(-1, 2), k1=-0.52, rho=1.5, lag=1.05, next_kind="|x|^(3/2)", nxt=3.5)
    v = _term()
    law = DressedLaw(1.5, (u, v), (CrossTerm("u", "v", -0.16, 0.01, "given"),))
    A0 = 0.5
    expect = sum(t.lag * t.k1 * t.x(A0) / (1 - t.rho * t.x(A0)) for t in (u, v))
    assert law.onset_shift(A0) == pytest.approx(expect, rel=1e-14)
    assert law.rate_value(A0) == pytest.approx(
        -sum(t.k1 * t.x(A0) / (1 - t.rho * t.x(A0)) for t in (u, v)) + 0.16 * u.x(A0) * v.x(A0), rel=1e-14)
    assert law.implicit() is None
    data = law.data(A0, 15.0)
    assert set(data["monomials"]) == {"u", "v"}
    for m in data["monomials"].values():
        assert {"k1", "k2_over_k1", "onset_lag"} <= set(m)
    assert data["cross"][0]["monomials"] == ["u", "v"] and data["cross"][0]["k2"] == -0.16
    assert data["onset"]["A_s"] == pytest.approx(A0 * math.exp(expect))


def test_validity_bound_is_where_the_next_term_equals_the_last():
    u = _term(name="u", c=-0.1, e=sympy.Rational(-1, 2), rho=1.5, next_kind="|x|^(3/2)", nxt=3.5)
    xb, why = u.x_bound()
    assert xb == pytest.approx((1.5 / 3.5) ** 2) and "3/2" in why
    assert xb * 3.5 ** 1 * math.sqrt(xb) == pytest.approx(1.5 * xb)  # g |x|^(3/2) = rho |x| there
    # A_bound: |c| A^e = x_bound
    assert abs(u.c) * u.amplitude_bound() ** -0.5 == pytest.approx(xb)
    v = _term(rho=0.29, nxt=0.08)
    assert v.x_bound()[0] == pytest.approx(1 / 0.29)  # the Pade pole comes first
