"""Normal runs print no raw numpy/scipy RuntimeWarnings: every such source is handled where it
arises. Each run here turns RuntimeWarning into an error; the step-budget advice fits the method used."""

from __future__ import annotations

import warnings

import pytest

from conftest import scene_toml, write_scene
from pulsemap.solvers.chain.peaks import StopRules
from pulsemap.solvers.chain.dns import IMPLICIT_METHODS, Chain, Integrator, simulate
from pulsemap.solvers.chain.peaks import budget_advice
from pulsemap.solvers.data.scene import load_scene, with_overrides
from pulsemap.solvers.studies.run import run_scene

ALL = ["map", "longwave", "energy-map", "energy-law", "momentum-map", "momentum-law", "dns"]


@pytest.mark.parametrize("sets", [{}, {"velocity": 1e-30}, {"velocity": 1e30}, {"velocity": 1e-6},
                                  {"R": "-mu*v^3"}, {"R": "-(u - mu*(1 - u^2)*v)"}, {"R": "mu*u"}],
                         ids=["damping", "v0 1e-30", "v0 1e30", "v0 1e-6", "cubic damping", "van der pol",
                              "unstable foundation"])
def test_runs_raise_no_runtime_warning(sets, tmp_path):
    scene = load_scene(write_scene(tmp_path, scene_toml("quiet", beads=60, contacts=(16, 50), eps=0.3)))
    scene = with_overrides(scene, **sets)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        result = run_scene(scene, methods=ALL)
    assert result["peaks"]["dns"] is not None


def test_the_step_budget_advice_does_not_suggest_the_method_in_use():
    assert "try method='LSODA'" in budget_advice("DOP853")
    assert "already an implicit method" in budget_advice("Rodas4")
    for method in IMPLICIT_METHODS:
        assert "LSODA'" not in budget_advice(method) and "max_steps" in budget_advice(method)
    for method, expect in (("LSODA", "already an implicit method"), ("DOP853", "try method='LSODA'")):
        res = simulate(Chain(60, 1.5, 1.0), (10, 50),
                       integrator=Integrator(method=method), stop=StopRules(max_steps=40), window="auto")
        assert res.stop_reason.startswith("step budget of 40 steps") and expect in res.stop_reason
        res = simulate(Chain(60, 1.5, 1.0), (10, 50),
                       integrator=Integrator(method=method), stop=StopRules(max_steps=40))
        assert res.stop_reason.startswith("step budget of 40 steps") and expect in res.stop_reason


def test_closed_form_laws_past_float64_are_a_blow_up_without_a_warning(tmp_path):
    """A parameter of -1e300 (anti-damping): the closed-form law's power overflows at once; no warning,
    no infinite peak, every contact past the seed without a value."""
    scene = load_scene(write_scene(tmp_path, scene_toml("blowup", beads=60, contacts=(16, 50), eps=0.3)))
    scene = with_overrides(scene, params={"mu": -1e300})
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        result = run_scene(scene, methods=["longwave", "energy-law", "momentum-law"])
    for method in ("longwave", "energy-law", "momentum-law"):
        peaks = result["peaks"][method]
        assert all(p is None for p in peaks), (method, peaks)
