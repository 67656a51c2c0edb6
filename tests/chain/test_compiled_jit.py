"""Non-polynomial R on the compiled engine: a generated numba force (derive/codegen_jitforce.py) that
the kernels call through a function pointer (solvers/chain/compiled_force.py), paper Eq. 1.

Stated tolerance: at rtol 1e-10 the compiled engine's leading-edge peaks agree with the scipy engine
(Hairer's DOP853, rtol 1e-11; Radau for a stiff R) to PEAK_TOL relative on every live contact, with
the same live contacts and stop rule. A non-smooth R (sign, Heaviside, abs) runs on the compiled
engine as the same ramp the scipy engine integrates (derive/codegen_jitforce.py); Coulomb's ramp is
stiff (Rodas4), whose error control is looser at the ramp's corners: at rtol 1e-11 its peaks agree
with the scipy engine's (BDF through a ramp) at rtol 1e-12 to PEAK_TOL, and the difference falls as
rtol does.
"""

from __future__ import annotations

import ctypes
import re

import numpy as np

from pulsemap.solvers.chain.contact_force import kernel_terms
import pytest

from conftest import regenerated
from pulsemap.symbolic.cache import cache_dir
from pulsemap.symbolic.codegen import PACKAGE_DIR
from pulsemap.symbolic.codegen_force import DELTA
from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.chain.equations import default_max_steps, make_rhs
from pulsemap.solvers.data.scene import load_scene, with_overrides
from pulsemap.solvers.models.codeload import force_module, jit_force_module
from pulsemap.solvers.studies.extent import dns_span
from pulsemap.solvers.studies.scene_chain import make_force

PEAK_TOL = 1e-7
FAST = Integrator(rtol=1e-10, atol=1e-12)
REFERENCE = Integrator(engine="scipy", method="DOP853", rtol=1e-11, atol=1e-13)


def rule_of(reason: str) -> str:
    return re.sub(r"[-+]?\d[\d.]*(e[-+]?\d+)?", "#", reason)


def scene_with(R: str, **params):
    scene = with_overrides(load_scene("fig8-eps0.1"), R=R, params=params)
    beads, span = dns_span(scene)
    return scene, beads, span, make_force(scene, beads)


@pytest.mark.parametrize("R", ["-mu*sin(u)", "-mu*v/(1+v^2)"])
def test_non_polynomial_R_agrees_with_the_scipy_engine(R):
    scene, beads, span, force = scene_with(R, mu=1.0)
    assert force.monomials is None and force.jit is not None
    fast = simulate(Chain(beads, scene.exponent, scene.velocity, force), span, integrator=FAST, window="auto")
    ref = simulate(Chain(beads, scene.exponent, scene.velocity, force), span, integrator=REFERENCE, window="auto")
    assert fast.engine == "compiled" and fast.method == "RK45" and ref.engine == "scipy"
    assert "generated numba function" in fast.engine_reason
    assert np.array_equal(fast.alive, ref.alive) and fast.alive.sum() >= 20
    assert rule_of(fast.stop_reason) == rule_of(ref.stop_reason)
    assert np.max(np.abs(fast.peaks[fast.alive] / ref.peaks[ref.alive] - 1.0)) < PEAK_TOL


def test_the_scipy_engine_takes_bdf_through_a_ramp_and_keeps_every_contact_at_loose_rtol():
    """LSODA's switching goes astray at Coulomb's corners (at rtol 1e-9 here it spent its budget before the
    first peak): 'auto' on the scipy engine runs BDF for a force with a ramp, which follows the compiled run."""
    scene, beads, span, force = scene_with("-mu*sign(v)", mu=1.0)
    scene = with_overrides(scene, eps=0.05)
    force = make_force(scene, beads)
    assert force.ramp
    chain = Chain(beads, scene.exponent, scene.velocity, force)
    ref = simulate(chain, span, integrator=Integrator(rtol=1e-12, atol=1e-14), window="auto")
    res = simulate(chain, span, integrator=Integrator(engine="scipy", rtol=1e-9, atol=1e-11), window="auto")
    assert res.method == "BDF" and np.array_equal(res.alive, ref.alive) and ref.alive.sum() >= 10
    assert np.max(np.abs(res.peaks[res.alive] / ref.peaks[ref.alive] - 1.0)) < 1e-5


@pytest.mark.parametrize("engine", ["compiled", "scipy"])
def test_a_loose_atol_is_capped_below_the_ramp_width_so_the_velocity_does_not_hop_across_it(engine):
    """At atol 1e-8 (rtol 1e-6) Rodas4's velocity steps hopped across Coulomb's ramp (half-width 1e-9) and
    spent the step budget by contact 47: a run through a ramp takes atol <= RAMP_ATOL x the half-width."""
    from pulsemap.solvers.chain.equations import RAMP_ATOL

    scene, beads, span, _ = scene_with("-mu*sign(v)", mu=0.2)
    chain = Chain(beads, scene.exponent, scene.velocity, make_force(scene, beads))
    ref = simulate(chain, span, integrator=Integrator(rtol=1e-12, atol=1e-14), window="auto")
    res = simulate(chain, span, integrator=Integrator(engine=engine, rtol=1e-6, atol=1e-8), window="auto")
    assert res.atol == pytest.approx(RAMP_ATOL * DELTA) and res.stop_reason.startswith("pulse died")
    assert np.array_equal(res.alive, ref.alive) and ref.alive.sum() >= 30
    assert np.max(np.abs(res.peaks[res.alive] / ref.peaks[ref.alive] - 1.0)) < 1e-2


def test_coulomb_stick_slip_stays_well_inside_the_step_budget_per_contact():
    """Coulomb friction's stick phases take the most steps per contact of any R (Rodas4 at the ramp's
    corners): at rtol 1e-10 and 1e-12 a run uses under a third of the default budget per contact peaked."""
    scene, beads, span, force = scene_with("-mu*sign(v)", mu=1.5)
    scene = with_overrides(scene, eps=0.02)
    chain = Chain(beads, scene.exponent, scene.velocity, make_force(scene, beads))
    for rtol in (1e-10, 1e-12):
        res = simulate(chain, span, integrator=Integrator(rtol=rtol, atol=rtol * 1e-2), window="auto")
        peaked = int(res.contacts[res.alive][-1])
        assert res.method == "Rodas4" and res.stop_reason.startswith("pulse died") and peaked >= 30
        assert res.steps < default_max_steps(peaked, rtol) / 3


@pytest.mark.slow
def test_stiff_non_polynomial_R_runs_rosenbrock_with_the_numba_jacobian():
    """-mu v/(1 + v^2) with eps mu = 1000: Rodas4 takes dF/dv from the generated dF/dv function."""
    scene, beads, _, force = scene_with("-mu*v/(1+v^2)", mu=10000.0)
    span = (1, scene.first_perturbed + 20)
    fast = simulate(Chain(beads, scene.exponent, scene.velocity, force), span,
                    integrator=Integrator(rtol=1e-9, atol=1e-11), window="auto")
    ref = simulate(Chain(beads, scene.exponent, scene.velocity, force), span,
                   integrator=Integrator(method="Radau", rtol=1e-11, atol=1e-13, engine="scipy"), window="auto")
    assert fast.engine == "compiled" and fast.method == "Rodas4" and "numba" in fast.engine_reason
    assert np.array_equal(fast.alive, ref.alive) and fast.alive.sum() >= 10
    assert np.max(np.abs(fast.peaks[fast.alive] / ref.peaks[ref.alive] - 1.0)) < PEAK_TOL


@pytest.mark.parametrize("R, eps, kernel", [("-mu*sign(v)", 0.02, "Rodas4"), ("-mu*abs(v)*v", 0.1, "RK45")])
def test_non_smooth_R_runs_compiled_and_converges_to_the_scipy_engine(R, eps, kernel):
    """Coulomb friction (a jump: the stiff ramp, Rodas4, stick phases) and -mu v|v| (a kink in dF/dv: the
    explicit kernel): the compiled peaks approach the scipy engine's as rtol falls, to PEAK_TOL at 1e-11."""
    scene, beads, span, force = scene_with(R, mu=1.5)
    scene = with_overrides(scene, eps=eps)
    force = make_force(scene, beads)
    chain = Chain(beads, scene.exponent, scene.velocity, force)
    ref = simulate(chain, span, integrator=Integrator(engine="scipy", rtol=1e-12, atol=1e-14), window="auto")
    assert ref.method == ("BDF" if kernel == "Rodas4" else "DOP853")  # the scipy engine's 'auto' through a ramp
    err = {}
    for rtol in (1e-9, 1e-11):
        fast = simulate(chain, span, integrator=Integrator(rtol=rtol, atol=rtol * 1e-2), window="auto")
        assert fast.engine == "compiled" and fast.method == kernel and "numba" in fast.engine_reason
        assert "ramp of half-width 1e-09" in fast.engine_reason
        assert np.array_equal(fast.alive, ref.alive) and fast.alive.sum() >= 10
        assert rule_of(fast.stop_reason) == rule_of(ref.stop_reason)
        err[rtol] = np.max(np.abs(fast.peaks[fast.alive] / ref.peaks[ref.alive] - 1.0))
    assert err[1e-11] < PEAK_TOL and err[1e-11] < err[1e-9] / 10


@pytest.mark.filterwarnings("ignore:First-class function type feature is experimental")
def test_the_compiled_right_hand_side_is_eq1_with_the_numpy_force():
    """The kernels' right-hand side with the numba force of an R that depends on i and on a per-bead
    random parameter equals the scipy engine's (numpy force module) on a random state."""
    from pulsemap.solvers.chain.compiled_ops import rhs

    scene = with_overrides(load_scene("fig13-seed1"), R="-k*v/(1+v^2) - 0.3*sin(u)*exp(-i/50)")
    beads = 60
    force = make_force(scene, beads)
    data = force.jit()
    assert data.arguments.shape[0] == beads  # a random draw per bead: one row each
    rng = np.random.default_rng(5)
    y = rng.normal(size=2 * beads) * 0.3
    got = np.empty_like(y)
    rhs(0.0, y, got, beads, 0, 1.5, False, 0.0, 0.0, 0.0, False, *data.kernel_args, kernel_terms(None, None))
    np.testing.assert_allclose(got, make_rhs(beads, 1.5, force)(0.0, y), rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("R", ["-mu*v/(1+v^2) - sin(u)*exp(-i/50)", "-mu*sign(v) + Heaviside(u)*u - mu*v*abs(v)"])
def test_numba_force_module_is_hash_headed_in_the_cache_and_matches_the_numpy_module(tmp_path, R):
    """The numba force and its slopes are the numpy module's, inside a non-smooth R's ramp too."""
    params = ("mu",)
    jit, plain = jit_force_module(R, params), force_module(R, params)
    path = cache_dir() / "generated" / f"{jit.__name__.removeprefix('pulsemap_generated_')}.py"
    assert path.is_file() and not (PACKAGE_DIR / path.name).exists()
    assert regenerated(path, tmp_path) == path.read_text(encoding="utf-8")
    rng = np.random.default_rng(2)
    for name in ("force", "force_dx", "force_dv"):
        call = getattr(jit, name).ctypes
        xs, vs = rng.normal(size=8), np.r_[rng.normal(size=5), 0.0, DELTA / 3, -DELTA / 2]
        for x, v, i in zip(xs, vs, (1.0, 7.0, 16.0, 40.0, 99.0, 3.0, 5.0, 8.0)):
            args = np.array([0.1, 0.7])  # eps, mu
            got = call(x, v, i, args.ctypes.data_as(ctypes.POINTER(ctypes.c_double)))
            want = getattr(plain, name)(np.array([x]), np.array([v]), np.array([i]), np.array([0.1]), 0.7)[0]
            assert got == pytest.approx(want, rel=1e-13, abs=1e-15)
