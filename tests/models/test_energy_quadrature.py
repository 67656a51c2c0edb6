"""Energy balance by direct quadrature of R over the wave (any R) against the monomial integrals."""

import numpy as np
import pytest

from pulsemap.symbolic.balance import balance_constants
from pulsemap.solvers.models.energy_quadrature import (EnergyQuadratureError, evaluate_energy_law,
                                                       iterate_energy_map, wave_table, work)


def test_wave_constants_match_mpmath():
    t = wave_table(1.5)
    c = balance_constants(["K1", "V1"], n=1.5)
    assert t.K1 == pytest.approx(c["K1"].value, rel=1e-12)
    assert t.V1 == pytest.approx(c["V1"].value, rel=1e-12)
    assert t.K1 / t.E1 == pytest.approx(5 / 9, rel=1e-10)  # virial theorem (n+1)/(n+3)


@pytest.mark.parametrize("a, b", [(1, 0), (0, 1), (3, 0), (2, 1), (1, 2)])
@pytest.mark.parametrize("A", [0.2, 1.0, 3.0])
def test_quadrature_of_a_monomial_is_its_integral(a, b, A):
    name = f"w_{a}{b}"
    w = balance_constants([name], n=1.5)[name].value
    s = 0.25
    expected = w * A ** (a + (1 + s) * (b + 1) - s)
    assert work(lambda x, v: x**a * v**b, A, wave_table(1.5)) == pytest.approx(expected, rel=1e-11)


def test_polynomial_in_disguise_gives_the_polynomial_rate():
    """-u (cos(v)^2 + sin(v)^2) is -u: same work to round-off, over amplitudes."""
    t = wave_table(1.5)
    for A in (0.1, 0.5, 2.0):
        disguised = work(lambda x, v: -x * (np.cos(v) ** 2 + np.sin(v) ** 2), A, t)
        assert disguised == pytest.approx(work(lambda x, v: -x, A, t), rel=1e-14)


def test_map_and_law_agree_at_small_eps():
    """sin(u) foundation: the map's steps and the law's ODE differ by O(eps^2) per contact."""
    eps = 1e-3

    def F(x, v, bead):
        return -eps * np.sin(x)

    m = iterate_energy_map(F, 1.5, 0.5, 15, 60)
    law = evaluate_energy_law(F, 1.5, 0.5, 15.0, np.arange(16, 61))
    assert m.status == "ok" and law.status == "ok"
    a_map, a_law = np.array(m.A, float), np.array(law.A, float)
    assert np.max(np.abs(a_map / a_law - 1)) < 1e-4
    assert a_law[-1] < a_law[0]  # a restoring foundation takes energy from the wave


def test_undefined_R_is_a_clear_error():
    with pytest.raises(EnergyQuadratureError, match="not finite"):
        work(lambda x, v: np.log(x - 10.0), 1.0, wave_table(1.5))
