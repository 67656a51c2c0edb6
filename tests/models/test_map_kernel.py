"""The compiled map kernel (map_kernel.py) against the reference Newton of map_iteration.py."""

from __future__ import annotations

import numpy as np
import pytest

from pulsemap.solvers.data.scene import load_scene
from pulsemap.solvers.models import codeload
from pulsemap.solvers.models.map_iteration import MapIterationError, iterate_map
from pulsemap.solvers.studies.scene_chain import parameter_values

VDP = "-(u - mu*(1-u**2)*v)"


def _module(scene_name: str, variant: str):
    scene = load_scene(scene_name)
    pert = scene.perturbation
    site = tuple(name for name, value in pert.params.items() if np.ndim(parameter_values(scene, scene.beads)[name]) > 0)
    mod = codeload.map_module(pert.R, list(pert.params), scene.exponent, "exact", variant, site)
    return scene, mod, parameter_values(scene, scene.beads)


@pytest.mark.parametrize("variant", ["paper", "corrected", "1d"])
@pytest.mark.parametrize("scene_name", ["vdp-mu3-v2.3", "fig6-eps0.3", "fig7-eps0.3", "fig13-seed1"])
def test_compiled_map_equals_the_reference(scene_name, variant):
    scene, mod, prm = _module(scene_name, variant)
    eps = float(scene.perturbation.eps)
    ref = iterate_map(mod, 0.6, 15, 120, eps, prm, engine="python")
    fast = iterate_map(mod, 0.6, 15, 120, eps, prm, engine="compiled")
    assert fast.engine == "compiled" and ref.engine == "python"
    assert fast.status == ref.status and fast.message == ref.message
    assert np.array_equal(fast.contacts, ref.contacts)
    np.testing.assert_allclose(fast.A, ref.A, rtol=1e-10)
    np.testing.assert_allclose(fast.forcing_ratio, ref.forcing_ratio, rtol=1e-8, atol=1e-14)


def test_corrected_map_is_constant_at_eps_zero():
    _, mod, prm = _module("vdp-mu3-v2.3", "corrected")
    run = iterate_map(mod, 0.7, 15, 500, 0.0, prm, engine="compiled")
    assert run.status == "ok"
    # corrected variant: alpha = beta for the exact profile, so A_i = A_{i-1} solves Eq. 23 at eps = 0
    np.testing.assert_allclose(run.A, 0.7, rtol=1e-9)


def test_stop_reasons_match_the_reference():
    statuses = set()
    for scene_name, eps in (("fig7-eps0.3", -3.0), ("fig8-eps0.3", 3.0), ("fig7-eps0.3", 5.0)):
        _, mod, prm = _module(scene_name, "paper")
        ref = iterate_map(mod, 0.6, 15, 400, eps, prm, engine="python")
        fast = iterate_map(mod, 0.6, 15, 400, eps, prm, engine="compiled")
        assert (fast.status, fast.message) == (ref.status, ref.message)
        np.testing.assert_allclose(fast.A, ref.A, rtol=1e-9)
        statuses.add(fast.status)
    assert statuses == {"no root", "died", "ok"}


def test_bad_engine_is_refused():
    _, mod, prm = _module("vdp-mu3-v2.3", "paper")
    with pytest.raises(MapIterationError, match="engine 'gpu'"):
        iterate_map(mod, 0.6, 15, 20, 0.1, prm, engine="gpu")
