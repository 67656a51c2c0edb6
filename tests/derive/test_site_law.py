"""Laws for a site-dependent R (derive/site_law.py): substituted back into their ODE."""

import numpy as np
import pytest
import sympy

from pulsemap.symbolic.balance import derive_balance
from pulsemap.symbolic.derivation import derive_all
from pulsemap.symbolic.perturbation import make_perturbation
from pulsemap.symbolic.site_law import A0, I, I0, SiteLaw


def _residual_at(law: SiteLaw, points):
    res = law.residual()
    vals = []
    for a0, i0, i in points:
        vals.append(float(res.xreplace({A0: a0, I0: i0, I: i})))
    return np.array(vals)


GRADED = make_perturbation("-k*u", 0.01, {"k": "1 + (i - 16)/50"})


@pytest.mark.parametrize("model", ["energy", "longwave"])
def test_graded_foundation_law_solves_its_ode(model):
    law = derive_all(GRADED).longwave if model == "longwave" else derive_balance(GRADED, "energy").law
    assert isinstance(law, SiteLaw)
    assert law.kind == "power law" and len(law.powers) == 1
    # the coefficient is linear in i (k is), so the law is closed form
    (C,) = law.coefficients
    assert sympy.degree(C, I) == 1
    pts = [(0.5, 15.0, 30.0), (0.8, 15.0, 60.5), (0.3, 20.0, 21.0)]
    scale = np.array([abs(float(law.scale)) * a0 ** float(law.Q) for a0, _, _ in pts])
    assert np.all(np.abs(_residual_at(law, pts)) < 1e-12 * scale)
    # and starts at A0
    assert float(law.law.xreplace({A0: 0.7, I0: 15.0, I: 15.0})) == pytest.approx(0.7, rel=1e-14)


def test_energy_site_coefficient_is_the_uniform_one_at_the_bead():
    """At contact index i the balance law uses bead i + 1/2: C(i) = c_uniform * k(i + 1/2)."""
    uni = derive_balance(make_perturbation("-k*u", 0.01, {"k": 1.0}), "energy").law
    site = derive_balance(GRADED, "energy").law
    (C,) = site.coefficients
    for i in (15.0, 40.0):
        k = 1 + (i + 0.5 - 16) / 50
        assert float(C.xreplace({I: i})) == pytest.approx(uni.coefficients[0] * k, rel=1e-14)


def test_explicit_i_in_R_and_several_powers():
    pert = make_perturbation("-(1 + i/100)*u - mu*v", 0.01, {"mu": 0.5})
    law = derive_balance(pert, "energy").law
    assert isinstance(law, SiteLaw)
    assert len(law.powers) == 2 and law.kind == "quadrature"
    assert "several powers" in law.why_quadrature


def test_per_bead_list_law_is_a_quadrature():
    pert = make_perturbation("-k*u", 0.01, {"k": [1.0 + 0.01 * j for j in range(40)]})
    law = derive_balance(pert, "energy").law
    assert law.kind == "quadrature" and "bead by bead" in law.why_quadrature
    assert "k(i + 1/2)" in str(law.coefficients[0])


def test_site_law_in_json_and_text():
    from pulsemap.symbolic.derivation import to_json, to_text

    d = derive_all(GRADED)
    data = to_json(d)
    assert data["longwave"]["site_dependent"] is True and data["longwave"]["kind"] == "power law"
    assert "A(i) =" in to_text(d)
