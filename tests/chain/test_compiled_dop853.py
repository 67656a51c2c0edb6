"""The compiled DOP853 kernel (solvers/chain/compiled_dop853.py), paper Eq. 1.

Its tableau is checked against scipy's copy of Hairer's and for its orders (one step of a scalar
ODE: solution order 8, dense output order 7, the embedded estimators orders 5 and 3); the kernel
against the independent scipy engine (Hairer's DOP853 on its own moving window) on the paper's
scenes, and against energy conservation on the unperturbed chain.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from pulsemap.solvers.chain.window import WindowSpec
from pulsemap.solvers.chain import compiled_dop853 as dop
from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.data.scene import load_scene, with_overrides
from pulsemap.solvers.studies.extent import dns_span
from pulsemap.solvers.studies.scene_chain import make_force

PEAK_TOL = 1e-7
COMPILED = dict(method="DOP853", rtol=1e-11, atol=1e-13, window=WindowSpec(accuracy=1e-8))
REFERENCE = dict(engine="scipy", method="DOP853", rtol=1e-11, atol=1e-13, window=WindowSpec(accuracy=1e-8))


def scene_run(name: str, window=None, **kw):
    scene = load_scene(name)
    beads, span = dns_span(scene)
    return simulate(Chain(beads, scene.exponent, scene.velocity, make_force(scene, beads)), span,
                    integrator=Integrator(**kw), window=window)


def rel(a, b) -> float:
    return float(np.max(np.abs(np.asarray(a) / np.asarray(b) - 1.0)))


def stop_rule(reason: str) -> str:
    """A stop reason without the numbers it quotes (they depend on the step grid)."""
    return re.sub(r"[-+]?\d[\d.]*(e[-+]?\d+)?", "#", reason)


def test_tableau_is_hairers():
    from scipy.integrate._ivp import dop853_coefficients as ref

    assert np.array_equal(dop.A, ref.A) and np.array_equal(dop.C, ref.C) and np.array_equal(dop.D, ref.D)
    assert np.array_equal(dop.E5, ref.E5[:12]) and np.array_equal(dop.E3, ref.E3[:12])
    assert ref.E5[12] == ref.E3[12] == 0.0  # the new point's f is not needed for the error: taken after acceptance


def _one_step(h: float, theta: float):
    """y' = y cos(t), y(0) = 1 over one step h, as the kernel combines its stages: (y1 error, dense
    output error at theta h, |err5|, |err3|)."""
    f = lambda t, y: y * math.cos(t)  # noqa: E731
    exact = lambda t: math.exp(math.sin(t))  # noqa: E731
    k = np.zeros(16)
    k[0] = f(0.0, 1.0)
    for s in range(1, 12):
        k[s] = f(dop.C[s] * h, 1.0 + h * np.dot(dop.A[s, :s], k[:s]))
    y1 = 1.0 + h * np.dot(dop.A[12, :12], k[:12])
    k[12] = f(h, y1)
    for s in range(13, 16):
        k[s] = f(dop.C[s] * h, 1.0 + h * np.dot(dop.A[s, :s], k[:s]))
    dy = y1 - 1.0
    rc = np.array([dy, h * k[0] - dy, 2.0 * dy - h * (k[12] + k[0])] + [h * np.dot(dop.D[r], k) for r in range(4)])
    v = rc[-1]
    for r in range(len(rc) - 2, -1, -1):  # compiled_track.dense_value's nesting
        v = rc[r] + ((1.0 - theta) if r % 2 == 0 else theta) * v
    return (abs(y1 - exact(h)), abs(1.0 + theta * v - exact(theta * h)),
            abs(h * np.dot(dop.E5, k[:12])), abs(h * np.dot(dop.E3, k[:12])))


def test_tableau_orders():
    """Halving h divides the local errors by 2^(p+1): p = 8 (solution), 7 (dense output), and the
    estimators' 5 and 3 (local error of the embedded solutions they measure)."""
    def slopes(h, which):
        big, small = _one_step(h, 0.37), _one_step(h / 2, 0.37)
        return [math.log2(big[i] / small[i]) for i in which]

    solution, dense = slopes(0.4, (0, 1))  # a larger h: at 0.1 the solution's error is at round-off
    err5, err3 = slopes(0.05, (2, 3))  # a smaller one: the estimators' asymptotic range
    assert solution > 8.5 and dense > 7.5, (solution, dense)
    assert 5.5 < err5 < 6.5 and 3.5 < err3 < 4.5, (err5, err3)


@pytest.mark.parametrize("name", ["fig6-eps0.1", "fig7-eps0.1", "fig8-eps0.1", "vdp-mu3-v2.3"])
def test_paper_scenes_agree_with_scipy(name):
    fast, ref = scene_run(name, **COMPILED), scene_run(name, **REFERENCE)
    assert fast.engine == "compiled" and fast.method == "DOP853" and "DOP853" in fast.engine_reason
    assert np.array_equal(fast.alive, ref.alive) and fast.alive.sum() >= 10
    assert stop_rule(fast.stop_reason) == stop_rule(ref.stop_reason)
    assert rel(fast.peaks[fast.alive], ref.peaks[ref.alive]) < PEAK_TOL
    assert np.max(np.abs(fast.peak_times[fast.alive] - ref.peak_times[ref.alive])) < 1e-5


def test_energy_conserved_without_perturbation():
    """R = 0: kinetic + contact energy is conserved (full chain and window), and less so at a loose rtol."""
    for window in (None, "auto"):
        res = simulate(Chain(200, 1.5, 1.0), (1, 190),
                       integrator=Integrator(method="DOP853", rtol=1e-10, atol=1e-12), window=window)
        assert res.engine == "compiled" and res.method == "DOP853" and res.stop_reason == "last contact peaked"
        assert 0.0 < res.energy_drift < 1e-8
        assert np.max(np.abs(res.total_energy / res.energy_initial - 1.0)) < 1e-8
    loose = simulate(Chain(200, 1.5, 1.0), (1, 190),
                     integrator=Integrator(method="DOP853", rtol=1e-5, atol=1e-7), window="auto")
    assert loose.energy_drift > 10 * res.energy_drift


def test_tolerance_convergence_on_a_damped_chain():
    """fig8-eps0.1: the peaks at rtol 1e-9 are much closer to rtol 1e-11's than those at rtol 1e-7."""
    ref = scene_run("fig8-eps0.1", **COMPILED)
    err = {}
    for rtol in (1e-7, 1e-9):
        res = scene_run("fig8-eps0.1", **{**COMPILED, "rtol": rtol, "atol": rtol * 1e-2})
        assert np.array_equal(res.alive, ref.alive)
        err[rtol] = rel(res.peaks[res.alive], ref.peaks[ref.alive])
    assert err[1e-9] < 0.05 * err[1e-7] and err[1e-7] < 1e-4


def test_a_scene_asking_for_dop853_runs_it_and_says_so():
    """`[dns] method = "DOP853"` (or --set dns.method=DOP853) runs the compiled kernel, and the run's
    record names it; `[dns] engine = "scipy"` still gets the reference engine; the peaks agree."""
    from pulsemap.solvers.studies.run import run_scene

    scene = with_overrides(load_scene("fig8-eps0.1"), contacts=(16, 30), dns={"method": "DOP853"})
    fast = run_scene(scene, methods=["dns"])
    ref = run_scene(with_overrides(scene, dns={"engine": "scipy"}), methods=["dns"])
    assert fast["dns"]["engine"] == "compiled" and fast["dns"]["method"] == "DOP853"
    assert "DOP853" in fast["dns"]["engine_reason"] and ref["dns"]["engine"] == "scipy"
    got, want = np.array(fast["peaks"]["dns"], float), np.array(ref["peaks"]["dns"], float)
    assert got.size == want.size >= 10 and rel(got, want) < 1e-7
