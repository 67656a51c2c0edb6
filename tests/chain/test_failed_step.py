"""A failed step size names where the on-site force is largest: an R that stays finite but grows without
bound (-v/(u - 1.5) as the wave pushes a bead to u = 1.5) stops every engine at the same bead."""

from __future__ import annotations

import re

import numpy as np
import pytest

from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.chain.equations import largest_force
from pulsemap.solvers.data.scene import load_scene, with_overrides
from pulsemap.solvers.studies.scene_chain import make_force
from pulsemap.solvers.studies.extent import dns_span

ENGINES = {  # name: (Integrator keywords, window)
    "compiled RK45, moving window": ({}, "auto"),
    "scipy RK45, whole chain": ({"engine": "scipy", "method": "RK45"}, None),
    "scipy DOP853, window (Fortran)": ({"engine": "scipy", "method": "DOP853"}, "auto"),
    "scipy Radau, window": ({"engine": "scipy", "method": "Radau"}, "auto"),
}


@pytest.fixture(scope="module")
def pole():
    scene = with_overrides(load_scene("default"), R="-v/(u-1.5)")
    beads, _ = dns_span(scene)
    return Chain(beads, scene.exponent, scene.velocity, make_force(scene, beads))


@pytest.mark.parametrize("engine", list(ENGINES))
def test_every_engine_names_the_bead_at_the_pole(pole, engine):
    kwargs, window = ENGINES[engine]
    res = simulate(pole, (15, 24), integrator=Integrator(**kwargs), window=window)
    found = re.search(r"largest at bead (\d+) \(u = ([-\d.e+]+), v = [-\d.e+]+\): \|eps R\| = ([\d.e+]+)",
                      res.stop_reason)
    assert res.stop_reason.startswith("integrator failed") and found, res.stop_reason
    bead, u, size = int(found[1]), float(found[2]), float(found[3])
    assert bead == 16 and abs(u - 1.5) < 1e-3 and size > 1e6


class _Force:
    def __init__(self, fn):
        self.force = fn


def test_largest_force_skips_non_finite_values_and_counts_from_the_window_start():
    y = np.array([0.1, 0.0, 0.4, 1.0, 0.2, -3.0])  # x_1, v_1, x_2, v_2, x_3, v_3
    assert largest_force(_Force(lambda x, v: v * 10.0), y, lo=40).startswith("; the on-site force is largest at bead 43 ")
    assert "bead 2 " in largest_force(_Force(lambda x, v: np.array([np.nan, 5.0, 1.0])), y)
    assert largest_force(_Force(lambda x, v: np.full(3, np.inf)), y) == ""
    assert largest_force(None, y) == ""
