"""R is evaluated only on perturbed beads (eps_i != 0), and where it is not finite or not real on one
of them the DNS stops naming the bead, the time and the term (models/onsite.py, chain/dns.py,
derive/codegen_force.py, derive/codegen_jitforce.py)."""

from __future__ import annotations

import math
import re
import warnings

import numpy as np
import pytest

from conftest import scene_toml, write_scene
from pulsemap.solvers.chain.dns import Chain, ForceNotFinite, Integrator, simulate
from pulsemap.solvers.data.scene import load_scene, with_overrides
from pulsemap.solvers.models.codeload import force_module, jit_force_module
from pulsemap.solvers.studies.extent import dns_span
from pulsemap.solvers.studies.scene_chain import make_force
from pulsemap.solvers.studies.run import run_scene

SINGULAR = "u*exp(1/(u-1))"  # infinite just past u = 1, which every bead of the default chain passes


def _scene(tmp_path, **sets):
    text = scene_toml("nonfinite", beads=60, contacts=(16, 40), methods=("dns",))
    return with_overrides(load_scene(write_scene(tmp_path, text)), **sets)


def test_numpy_force_module_does_not_evaluate_R_where_eps_is_zero():
    mod = force_module(SINGULAR, [])
    x = np.array([1.0, 1.0 + 1e-6, 0.5, 0.25])
    v = np.zeros(4)
    i = np.arange(1.0, 5.0)
    eps = np.array([0.0, 0.0, 0.1, 0.2])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # R at u = 1 or just past it would warn (division by zero, overflow)
        got = [np.asarray(f(x, v, i, eps)) for f in (mod.force, mod.force_dx, mod.force_dv)]
    assert np.all(got[0][:2] == 0.0) and np.all(got[1][:2] == 0.0)
    want = eps[2:] * x[2:] * np.exp(1.0 / (x[2:] - 1.0))  # the formula, independently
    assert np.allclose(got[0][2:], want, rtol=1e-15, atol=0.0)
    d = np.exp(1.0 / (x[2:] - 1.0)) * (1.0 - x[2:] / (x[2:] - 1.0) ** 2)  # d/du of u exp(1/(u - 1))
    assert np.allclose(got[1][2:], eps[2:] * d, rtol=1e-14, atol=0.0)


def test_numba_force_module_does_not_evaluate_R_where_eps_is_zero():
    jit = jit_force_module(SINGULAR, [])
    unperturbed, perturbed = np.array([0.0]), np.array([0.1])
    for f in (jit.force, jit.force_dx):
        assert f.ctypes(1.0, 0.0, 1.0, unperturbed.ctypes.data_as(f.ctypes.argtypes[3])) == 0.0
        past = f.ctypes(1.0 + 1e-6, 0.0, 20.0, perturbed.ctypes.data_as(f.ctypes.argtypes[3]))
        assert math.isinf(past) or math.isnan(past)  # numpy error model: no exception from inside a kernel
    value = jit.force.ctypes(0.5, 0.0, 20.0, perturbed.ctypes.data_as(jit.force.ctypes.argtypes[3]))
    assert value == pytest.approx(0.1 * 0.5 * math.exp(1.0 / (0.5 - 1.0)), rel=1e-15)


@pytest.mark.parametrize("lo, hi", [(0, 40), (10, 30), (20, 60)])
def test_window_force_equals_eps_times_R_bead_by_bead(lo, hi):
    mod = force_module("-mu*sin(u) + u^3*v", ["mu"])
    from pulsemap.solvers.models.onsite import onsite_force

    force = onsite_force(mod, 60, 16, 0.1, {"mu": 2.0}).restrict(lo, hi)
    rng = np.random.default_rng(7)
    x, v = rng.uniform(-1, 1, hi - lo), rng.uniform(-1, 1, hi - lo)
    eps = np.where(np.arange(lo + 1, hi + 1) >= 16, 0.1, 0.0)
    np.testing.assert_allclose(force.force(x, v), eps * (-2.0 * np.sin(x) + x**3 * v), rtol=1e-14, atol=0.0)
    np.testing.assert_allclose(force.dforce_dx(x, v), eps * (-2.0 * np.cos(x) + 3 * x**2 * v), rtol=1e-14, atol=0.0)
    np.testing.assert_allclose(force.dforce_dv(x, v), eps * x**3, rtol=1e-14, atol=0.0)


def test_coefficient_singular_on_an_unperturbed_bead_is_never_evaluated(tmp_path):
    """-mu*v/(i - 10) is infinite at bead 10 (unperturbed): the same physics as -mu*v with mu_i = 1/(i - 10)
    given per bead."""
    by_i = run_scene(_scene(tmp_path, R="-mu*v/(i-10)", params={"mu": 1.0}), methods=["dns"])
    listed = [0.0] * 15 + [1.0 / (i - 10) for i in range(16, 61)]
    by_list = run_scene(_scene(tmp_path, R="-mu*v", params={"mu": listed}), methods=["dns"])
    a, b = np.array(by_i["peaks"]["dns"], float), np.array(by_list["peaks"]["dns"], float)
    assert np.all(np.isfinite(a)) and a.size == 25
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=0.0)


def _failure(scene, engine: str) -> ForceNotFinite:
    beads, span = dns_span(scene)
    with pytest.raises(ForceNotFinite) as info:
        simulate(Chain(beads, scene.exponent, scene.velocity, make_force(scene, beads)), span,
                 integrator=Integrator(engine=engine), window="auto")
    return info.value


def test_both_engines_stop_at_the_first_perturbed_bead_when_it_reaches_the_singularity(tmp_path):
    """Beads 1..15 pass u = 1 long before bead 16 does: the run stops at bead 16, and the compiled and
    scipy engines (independent integrators) agree on when it gets there."""
    scene = _scene(tmp_path, R=SINGULAR, params={})
    compiled, scipy = _failure(scene, "compiled"), _failure(scene, "scipy")
    for exc in (compiled, scipy):
        assert exc.bead == 16 and exc.t is not None
        assert 1.0 < exc.x < 1.0 + 1.0 / 709.0  # where exp(1/(u - 1)) overflows float64
        assert math.isinf(exc.value) or math.isnan(exc.value)
    assert compiled.t == pytest.approx(scipy.t, rel=1e-3)


@pytest.mark.parametrize("engine", ["compiled", "scipy"])
def test_complex_R_names_the_bead_and_term(engine, tmp_path, capsys):
    from pulsemap.solvers.cli.main import main

    path = write_scene(tmp_path, scene_toml("complex", beads=60, contacts=(16, 40), methods=("dns",)))
    code = main(["run", str(path), "--set", "perturbation.R=sqrt(1-u)-1", "--set", f"dns.engine={engine}", "--quiet"])
    err = capsys.readouterr().err.splitlines()[-1]
    assert code == 2
    assert "at bead 16" in err and "its term sqrt(1 - u) is complex there" in err and "DNS stopped at t = " in err


def test_energy_balance_refuses_a_path_over_a_pole_and_keeps_a_pole_R_does_not_feel(tmp_path):
    """u*exp(1/(u - 1)) diverges past u = 1, which the wave's path crosses: the quadrature nodes alone step
    over it (a finite, wrong work). u*exp(-1/(u - 1)^2) has the same pole in a term but R is smooth there."""
    refused = run_scene(_scene(tmp_path, R=SINGULAR, params={}), methods=["energy-map"])
    assert refused["peaks"]["energy-map"] is None  # the model's own entry says why; the run goes on
    assert re.search(r"its term 1/\(u - 1\) is infinite where the wave takes bead 16", refused["energy-map"]["failed"])
    smooth = run_scene(_scene(tmp_path, R="u*exp(-1/(u-1)^2)", params={}), methods=["energy-map"])
    peaks = np.array(smooth["peaks"]["energy-map"], float)
    assert peaks.size == 25 and np.all(np.isfinite(peaks)) and np.all(peaks > 0)
