"""Roots of Eq. 41 (pulsemap.solvers.models.stationary_shock.roots): the grid is evaluated in one numpy call."""

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.optimize import brentq

from pulsemap.solvers.models.codeload import map_module
from pulsemap.solvers.data.scene import load_scene
from pulsemap.solvers.models.stationary_shock import roots


def _roots_pointwise(module, params, lo=1e-8, hi=1e6, points=3000):
    """The reference: Phi at each grid point by a scalar call, sign changes refined by brentq."""
    args = tuple(params[k] for k in module.PARAMS)

    def phi(a):
        return module.stationary(a, *args)[0]

    grid = np.geomspace(lo, hi, points)
    vals = [phi(a) for a in grid]
    return [brentq(phi, grid[j], grid[j + 1], xtol=1e-15 * grid[j + 1], rtol=1e-15)
            for j in range(points - 1) if np.sign(vals[j]) * np.sign(vals[j + 1]) < 0]


@pytest.mark.parametrize("profile", ["exact", "pade"])
def test_roots_equal_the_pointwise_scan(profile):
    pert = load_scene("vdp-mu3-v2.3").perturbation  # Van der Pol foundation
    mod = map_module(pert.text, ["mu"], 1.5, profile, "1d")
    counts = {}
    for mu in (1.0, 1.47, 1.5, 3.0, -2.0):
        got = roots(mod, {"mu": mu})
        assert got == _roots_pointwise(mod, {"mu": mu})
        counts[mu] = len(got)
        for a in got:
            assert abs(mod.stationary(a, mu)[0]) < 1e-12
    assert counts[1.0] == 0 and counts[3.0] == 2  # no shock below the fold (mu* ~ 1.47), a pair above it


def test_roots_of_a_known_polynomial_and_of_a_constant():
    cubic = SimpleNamespace(PARAMS=("c",), ARGS=(("c", 0),), stationary=lambda A, c: (c * (A - 1) * (A - 10) * (A - 100), 0))
    assert roots(cubic, {"c": 2.0}) == pytest.approx([1.0, 10.0, 100.0], rel=1e-14)
    constant = SimpleNamespace(PARAMS=("c",), ARGS=(("c", 0),), stationary=lambda A, c: (c, 0))  # a scalar for any A
    assert roots(constant, {"c": 2.0}) == [] and roots(constant, {"c": 0.0}) == []
