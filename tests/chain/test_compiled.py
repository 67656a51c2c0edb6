"""The compiled engine (solvers/chain/compiled.py) against the independent scipy engine, paper Eq. 1.

Stated tolerance: at rtol 1e-10 and window accuracy 1e-8 the compiled engine's leading-edge peaks
agree with the scipy reference (Hairer's DOP853, rtol 1e-11, its own moving window) to PEAK_TOL
relative on every live contact, with the same live contacts and the same stop rule.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from pulsemap.solvers.chain.window import WindowSpec
from pulsemap.solvers.chain.force_table import MonomialTable
from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.chain.peaks import StopRules
from pulsemap.solvers.chain.window import rule_for_accuracy
import pulsemap.solvers.data as data_package
from pulsemap.solvers.data.scene import load_scene, with_overrides
from pulsemap.solvers.studies.extent import dns_span
from pulsemap.solvers.studies.scene_chain import make_force
from pulsemap.solvers.studies.run import run_scene

PEAK_TOL = 1e-7
COMPILED = dict(rtol=1e-10, atol=1e-12, window=WindowSpec(accuracy=1e-8))
REFERENCE = dict(engine="scipy", method="DOP853", rtol=1e-11, atol=1e-13, window=WindowSpec(accuracy=1e-8))


def rel(a, b) -> float:
    return float(np.max(np.abs(np.asarray(a) / np.asarray(b) - 1.0)))


def rule_of(reason: str) -> str:
    """A stop reason without the times and step sizes it quotes (they depend on the step grid)."""
    return re.sub(r"[-+]?\d[\d.]*(e[-+]?\d+)?", "#", reason)


SUITE = Path(data_package.__file__).parent / "scenes" / "suite"


def scene_run(name: str, window=None, **kw):
    scene = load_scene(SUITE / f"{name}.toml" if (SUITE / f"{name}.toml").is_file() else name)
    beads, span = dns_span(scene)
    return simulate(Chain(beads, scene.exponent, scene.velocity, make_force(scene, beads)), span,
                    integrator=Integrator(**kw), window=window)


@pytest.mark.parametrize("name", ["fig6-eps0.1", "fig6-eps0.3", "fig7-eps0.1", "fig7-eps0.3", "fig8-eps0.1",
                                  "fig8-eps0.3", "vdp-mu3-v2.3"])
def test_paper_scenes_agree_with_scipy(name):
    fast, ref = scene_run(name, **COMPILED), scene_run(name, **REFERENCE)
    assert fast.engine == "compiled" and fast.mode == "window/compiled" and ref.engine == "scipy"
    assert np.array_equal(fast.alive, ref.alive) and fast.alive.sum() >= 10
    assert rule_of(fast.stop_reason) == rule_of(ref.stop_reason)
    assert rel(fast.peaks[fast.alive], ref.peaks[ref.alive]) < PEAK_TOL
    assert np.max(np.abs(fast.peak_times[fast.alive] - ref.peak_times[ref.alive])) < 1e-5
    # front diagnostics (chain/front.py): the pulse's energy at each peak, to 1e-6 of the initial
    # energy (beads k-8 and behind carry the wake, which the window cuts; its total with R != 0
    # depends on the window: dropped beads keep trading energy with the on-site potential)
    gap = np.abs(fast.pulse_energy[fast.alive] - ref.pulse_energy[ref.alive]) / ref.energy_initial
    assert fast.energy_initial == ref.energy_initial and np.max(gap) < 1e-6


def test_energy_conserved_without_perturbation():
    """R = 0: Eq. 1 conserves kinetic + contact energy; the window counts what dropped beads carried."""
    for window in (None, "auto"):
        res = simulate(Chain(200, 1.5, 1.0), (1, 190), integrator=Integrator(rtol=1e-10, atol=1e-12), window=window)
        assert res.engine == "compiled" and res.stop_reason == "last contact peaked"
        assert res.energy_drift is not None and 0.0 < res.energy_drift < 1e-7
        assert np.max(np.abs(res.total_energy / res.energy_initial - 1.0)) < 1e-7 and res.energy_initial == 0.5
    loose = simulate(Chain(200, 1.5, 1.0), (1, 190), integrator=Integrator(rtol=1e-6, atol=1e-8), window="auto")
    assert loose.energy_drift > 10 * res.energy_drift


def test_unperturbed_peaks_match_scipy_full_chain():
    """Full chain (window=None) on both engines: the solitary wave's peaks agree."""
    fast = simulate(Chain(80, 1.5, 1.0), (1, 70), integrator=Integrator(rtol=1e-10, atol=1e-12))
    ref = simulate(Chain(80, 1.5, 1.0), (1, 70),
                   integrator=Integrator(method="DOP853", rtol=1e-12, atol=1e-14, engine="scipy"))
    assert fast.mode == "full" and fast.engine == "compiled" and fast.window_beads == 80
    assert rel(fast.peaks, ref.peaks) < PEAK_TOL


def test_tolerance_convergence():
    """Peaks at rtol 1e-8 are much closer to rtol 1e-10's than rtol 1e-6's are."""
    ref = scene_run("vdp-mu3-v2.3", **COMPILED)
    err = {}
    for rtol in (1e-6, 1e-8):
        res = scene_run("vdp-mu3-v2.3", **{**COMPILED, "rtol": rtol, "atol": rtol * 1e-2})
        assert np.array_equal(res.alive, ref.alive)
        err[rtol] = rel(res.peaks[res.alive], ref.peaks[ref.alive])
    assert err[1e-8] < 0.1 * err[1e-6]
    assert err[1e-6] < 1e-4


def test_million_beads_cost_the_same_window():
    """The window is independent of N: beads = 10^6 integrates as many beads as beads = 140."""
    scene = load_scene("vdp-mu3-v2.3")
    force = make_force(scene, 140)
    assert force.monomials.coefficients.shape[1] == scene.first_perturbed  # uniform R: no O(N) table
    tol = Integrator(rtol=1e-10, atol=1e-12)
    small = simulate(Chain(140, scene.exponent, scene.velocity, force), (15, 120), integrator=tol,
                     window=WindowSpec(accuracy=1e-8))
    huge = simulate(Chain(1_000_000, scene.exponent, scene.velocity, force), (15, 120), integrator=tol,
                     window=WindowSpec(accuracy=1e-8))
    assert huge.window_beads == small.window_beads <= rule_for_accuracy(1e-8).behind + 12
    assert huge.beads == 1_000_000 and huge.stop_reason == small.stop_reason == "last contact peaked"
    assert np.array_equal(huge.peaks, small.peaks) and huge.nfev == small.nfev


@pytest.mark.parametrize("accuracy", [1e-4, 1e-6])
def test_window_rule_keeps_its_accuracy(accuracy):
    """rule_for_accuracy's window costs less than ``accuracy`` against the full chain on the damped
    scene (a decaying pulse is the window's worst case); behind is exactly the rule's count."""
    tight = dict(rtol=1e-12, atol=1e-14)
    full = scene_run("fig8-eps0.1", **tight)
    win = scene_run("fig8-eps0.1", **tight, window=WindowSpec(accuracy=accuracy))
    rule = rule_for_accuracy(accuracy)
    assert full.mode == "full" and win.window_rule == rule
    assert rule.behind + 2 <= win.window_beads <= rule.behind + 12 < full.window_beads
    assert np.array_equal(win.alive, full.alive)
    assert rel(win.peaks[win.alive], full.peaks[full.alive]) < accuracy


def test_engine_selection_and_reasons():
    scene = load_scene("fig8-eps0.1")
    beads, span = dns_span(scene)
    force = make_force(scene, beads)
    short = (15, 30)
    assert simulate(Chain(beads, 1.5, 1.0, force), short).engine == "compiled"
    by_request = simulate(Chain(beads, 1.5, 1.0, force), short, integrator=Integrator(engine="scipy"))
    assert by_request.engine == "scipy" and "requested" in by_request.engine_reason
    dop = simulate(Chain(beads, 1.5, 1.0, force), short,
                   integrator=Integrator(method="DOP853"))  # tests/chain/test_compiled_dop853.py
    assert dop.engine == "compiled" and dop.method == "DOP853" and "DOP853" in dop.engine_reason
    lsoda = simulate(Chain(beads, 1.5, 1.0, force), short, integrator=Integrator(method="LSODA"))
    assert lsoda.engine == "scipy" and "LSODA has no compiled kernel" in lsoda.engine_reason
    assert "monomial table (dense form" in simulate(Chain(beads, 1.5, 1.0, force), short).engine_reason
    sine = with_overrides(scene, R="-mu*sin(u)")  # tests/chain/test_compiled_jit.py compares its peaks
    res = simulate(Chain(beads, 1.5, 1.0, make_force(sine, beads)), short)
    assert res.engine == "compiled" and "generated numba function" in res.engine_reason
    with pytest.raises(ValueError, match="engine"):
        simulate(Chain(beads, 1.5, 1.0, force), short, integrator=Integrator(engine="numba"))


def test_stiff_scene_goes_to_the_compiled_rosenbrock_kernel():
    """method 'auto' on a stiff force: Rodas4 on the compiled engine, the scipy engine's LSODA on request
    (tests/chain/test_compiled_stiff.py compares their peaks)."""
    res = scene_run("damp-1000", window="auto")
    assert res.engine == "compiled" and res.method == "Rodas4" and "stiffness hint" in res.engine_reason
    assert scene_run("damp-1000", window="auto", engine="scipy").method == "LSODA"


def test_scene_key_and_run_record_the_engine():
    scene = with_overrides(load_scene("fig8-eps0.1"), contacts=(16, 30), dns={"engine": "scipy"})
    out = run_scene(scene, methods=["dns"])
    assert out["dns"]["engine"] == "scipy" and out["scene"]["dns"]["engine"] == "scipy"
    fast = run_scene(with_overrides(scene, dns={"engine": "compiled"}), methods=["dns"])
    assert fast["dns"]["engine"] == "compiled"
    got, ref = np.array(fast["peaks"]["dns"], float), np.array(out["peaks"]["dns"], float)
    assert rel(got, ref) < 1e-6
    # sweep workers (studies/points.py) take the scene's engine from the plain chain
    from pulsemap.solvers.studies.points import dns_task, plain_chain

    assert dns_task(plain_chain(scene))["method"] == "DOP853"  # scipy, method 'auto'
    assert dns_task(plain_chain(with_overrides(scene, dns={"engine": "compiled"})))["method"] == "RK45"


def test_blow_up_and_step_budget_stop_like_scipy():
    unstable = load_scene(SUITE / "unstable.toml")
    beads, span = dns_span(unstable)
    force = make_force(unstable, beads)
    fast = simulate(Chain(beads, 1.5, 1.0, force), span, integrator=Integrator(rtol=1e-8, atol=1e-10), window="auto")
    ref = simulate(Chain(beads, 1.5, 1.0, force), span,
                   integrator=Integrator(method="RK45", rtol=1e-8, atol=1e-10, engine="scipy"), window="auto")
    assert fast.engine == "compiled" and fast.blew_up and ref.blew_up
    assert rule_of(fast.stop_reason) == rule_of(ref.stop_reason)
    budget = simulate(Chain(200, 1.5, 1.0), (1, 190), stop=StopRules(max_steps=50), window="auto")
    assert budget.steps == 50 and budget.stop_reason.startswith("step budget of 50 steps used up")
    assert budget.alive.sum() < 190 and np.all(np.isfinite(budget.peaks[budget.alive]))


def test_monomial_table_is_the_generated_force():
    """The generated module's monomial table (expanded R) evaluates to its eps_i R_i (R as written),
    bead by bead: a site-dependent random parameter, several monomials, a coefficient in i."""
    rng = np.random.default_rng(3)
    for name, R in (("fig13-seed1", None), ("vdp-mu3-v2.3", None), ("fig8-eps0.1", "-mu*v + 0.3*u^2*v - u^3"),
                    ("fig8-eps0.1", "-mu*(1 + i/50)*(v - u)^2*v")):
        scene = load_scene(name)
        if R is not None:
            scene = with_overrides(scene, R=R)
        beads = scene.beads or 140
        force = make_force(scene, beads)
        table: MonomialTable = force.monomials
        x, v = rng.normal(size=beads), rng.normal(size=beads)
        cols = np.minimum(np.arange(beads), table.coefficients.shape[1] - 1)
        mine = sum(table.coefficients[m, cols] * x ** a * v ** b for m, (a, b) in enumerate(table.exponents))
        np.testing.assert_allclose(mine, force.force(x, v), rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("name, v0", [("fig6-eps0.1", 2e3), ("fig8-eps0.1", 2e3), ("vdp-mu3-v2.3", 5e-4)])
def test_extreme_velocity_runs_compiled_in_the_unit_frame(name, v0):
    """v0 outside [1e-3, 1e3] runs at v0 = 1 (chain/scaling.py) with the table scaled like the force."""
    scene = load_scene(name)
    force = make_force(scene, 60)
    fast = simulate(Chain(60, 1.5, v0, force), (15, 40), integrator=Integrator(rtol=1e-10, atol=1e-12), window="auto")
    ref = simulate(Chain(60, 1.5, v0, force), (15, 40), window="auto",
                   integrator=Integrator(engine="scipy", method="DOP853", rtol=1e-10, atol=1e-12))
    assert fast.engine == "compiled" and ref.engine == "scipy" and np.array_equal(fast.alive, ref.alive)
    assert fast.alive.sum() >= 5 and rel(fast.peaks[fast.alive], ref.peaks[ref.alive]) < PEAK_TOL


@pytest.mark.parametrize("stiff", [False, True])
def test_progress_lines_pause_the_kernel_without_changing_a_number(monkeypatch, stiff):
    """With progress the compiled kernels (explicit and Rosenbrock) pause every PAUSE_STEPS accepted
    steps for a line on stderr; the peaks, times and counts equal those of an unpaused run bit for bit."""
    from pulsemap.solvers.chain import compiled, plan
    from pulsemap.solvers.chain.dns_progress import DNSProgress

    scene = load_scene("fig8-eps0.1")
    beads, span = dns_span(scene)
    table = make_force(scene, beads).monomials
    method = plan.STIFF_METHOD if stiff else plan.METHOD
    args = (plan.Plan("compiled", method, rule_of_window(), "", ""), Integrator(rtol=1e-8, atol=1e-10),
            StopRules(t_max=1e4, max_steps=10**6))
    plain = compiled.prepare(Chain(beads, 1.5, 1.0), span, table, *args)
    code_plain = compiled.drive(plain, compiled.kernel_for(plain)[0])
    monkeypatch.setattr(compiled, "PAUSE_STEPS", 50)
    lines: list[str] = []
    paused = compiled.prepare(Chain(beads, 1.5, 1.0), span, table, *args)
    code_paused = compiled.drive(paused, compiled.kernel_for(paused)[0], report=DNSProgress("dns", paused.last, every=0.0, sink=lines.append))
    assert code_paused == code_plain
    steps = int(plain.st[3])  # compiled_layout.STEPS
    assert len(lines) == steps // 50 and all(line.startswith("[dns] contact ") for line in lines)
    assert f"compiled {method}" in lines[-1]
    for name in ("peaks", "times", "pulse_e", "total_e", "st", "fs"):
        assert np.array_equal(getattr(plain, name), getattr(paused, name), equal_nan=True), name


def rule_of_window():
    return rule_for_accuracy(1e-8)
