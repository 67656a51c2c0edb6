"""Moving-window DNS of paper Eq. 1 (solvers/window.py) against the full chain."""

from __future__ import annotations

import numpy as np
import pytest

from pulsemap.solvers.chain.window import WindowSpec
from pulsemap.solvers.chain.dns import Chain, Integrator, OnSiteForce, make_rhs, simulate
from pulsemap.solvers.chain.window import (
    MIN_WIDTH,
    WindowRule,
    needs_shift,
    plan,
    resolve_rule,
    rule_for_accuracy,
    window_accuracy_for,
    shift_state,
)

BEADS, LAST = 200, 190
TIGHT = Integrator(method="DOP853", rtol=1e-12, atol=1e-14, engine="scipy")  # integrator error << window error


def damping(eps_mu: float, beads: int, first: int = 16, restrict: bool = True) -> OnSiteForce:
    """F = -eps*mu*v on beads >= first; with restrict() for the window when asked."""
    mask = (np.arange(1, beads + 1) >= first).astype(float)

    def make(m: np.ndarray) -> OnSiteForce:
        return OnSiteForce(lambda x, v: -eps_mu * m * v, lambda x, v: np.zeros(len(m)),
                           lambda x, v: -eps_mu * m, stiffness_hint=eps_mu)

    full = make(mask)
    if not restrict:
        return full
    return OnSiteForce(full.force, full.dforce_dx, full.dforce_dv, eps_mu,
                       restrict=lambda lo, hi: make(mask[lo:hi]))


def rel(a, b) -> float:
    return float(np.max(np.abs(np.asarray(a) / np.asarray(b) - 1.0)))


@pytest.fixture(scope="module")
def unperturbed():
    full = simulate(Chain(BEADS, 1.5, 1.0), (1, LAST), integrator=TIGHT)
    win = simulate(Chain(BEADS, 1.5, 1.0), (1, LAST), integrator=TIGHT, window=WindowSpec(accuracy=1e-8))
    return full, win


def test_window_matches_full_chain_unperturbed(unperturbed):
    full, win = unperturbed
    assert full.mode == "full" and win.mode.startswith("window")
    assert win.stop_reason == full.stop_reason == "last contact peaked"
    assert rel(win.peaks, full.peaks) < 1e-8
    assert rel(np.diff(win.peak_times), np.diff(full.peak_times)) < 1e-8


def test_window_really_is_smaller(unperturbed):
    full, win = unperturbed
    assert full.window_beads == BEADS
    assert win.window_beads <= win.window_rule.width < BEADS // 4
    assert win.window_shifts >= (LAST - 40) // win.window_rule.chunk
    # the work per contact stays that of the full chain (no hidden re-integration)
    assert win.nfev < 1.6 * full.nfev


def test_window_energy_and_formed_peaks(unperturbed):
    _, win = unperturbed
    assert win.energy_drift is not None and win.energy_drift < 1e-9  # incl. what left the window
    formed = win.peaks[29:]  # contacts 30..190
    assert rel(formed, formed[0]) < 1e-6


@pytest.mark.parametrize("eps_mu", [0.01, 0.3])
def test_window_matches_full_chain_damped(eps_mu):
    beads, last = 80, 70
    full = simulate(Chain(beads, 1.5, 1.0, damping(eps_mu, beads)), (16, last), integrator=TIGHT)
    win = simulate(Chain(beads, 1.5, 1.0, damping(eps_mu, beads)), (16, last), integrator=TIGHT, window="auto")
    assert np.array_equal(win.alive, full.alive) and win.alive.sum() >= 15
    ok = full.alive
    assert rel(win.peaks[ok], full.peaks[ok]) < 1e-8
    assert win.window_beads < beads


def test_force_without_restrict_is_embedded():
    beads = 80
    a = simulate(Chain(beads, 1.5, 1.0, damping(0.05, beads)), (16, 60), window=24)
    b = simulate(Chain(beads, 1.5, 1.0, damping(0.05, beads, restrict=False)), (16, 60), window=24)
    assert np.array_equal(a.peaks, b.peaks)


@pytest.mark.parametrize("method, engine", [("DOP853", "scipy"), ("RK45", "fortran"), ("LSODA", "auto")])
def test_engines_and_methods_agree(method, engine):
    beads = 80
    ref = simulate(Chain(beads, 1.5, 1.0, damping(0.05, beads)), (16, 70), integrator=TIGHT)
    res = simulate(Chain(beads, 1.5, 1.0, damping(0.05, beads)), (16, 70),
                   integrator=Integrator(method=method, rtol=1e-10, atol=1e-12), window=WindowSpec(engine=engine))
    assert res.mode == f"window/{'scipy' if method == 'LSODA' else engine}"
    assert res.alive.all() and rel(res.peaks, ref.peaks) < 1e-6


def test_narrow_ahead_extends_the_window_without_error():
    """ahead = 2: the precursor reaches the window's edge; the step is redone wider."""
    full = simulate(Chain(60, 1.5, 1.0), (1, 50), integrator=TIGHT)
    win = simulate(Chain(60, 1.5, 1.0), (1, 50), integrator=TIGHT, window=WindowRule(behind=8, ahead=2, chunk=4))
    assert rel(win.peaks, full.peaks) < 1e-9
    assert win.window_shifts > (50 - 8) // 4  # extensions on top of the regular shifts


def test_free_boundary_is_worse_than_coast_on_a_dying_pulse():
    beads = 60
    f = damping(0.3, beads)
    full = simulate(Chain(beads, 1.5, 1.0, f), (16, 36), integrator=TIGHT)
    errs = {}
    for boundary in ("coast", "free"):
        w = simulate(Chain(beads, 1.5, 1.0, f), (16, 36),
                     integrator=TIGHT, window=WindowRule(behind=8, boundary=boundary))
        errs[boundary] = rel(w.peaks, full.peaks)
    assert errs["coast"] < errs["free"]


def test_window_pieces():
    rhs = make_rhs(3, 1.5, None, left=lambda t: 0.5, wall=True)
    y = np.array([0.1, 0.0, 0.3, 0.0, 0.2, 0.0])  # x = 0.1, 0.3, 0.2
    a = rhs(0.0, y)[1::2]
    assert np.allclose(a, [0.4**1.5, -(0.1**1.5), 0.1**1.5 - 0.2**1.5])
    y = np.arange(8.0)
    assert np.array_equal(shift_state(y, 2, 3, 7), [2, 3, 4, 5, 6, 7, 0, 0])
    rule = WindowRule(behind=10, ahead=5, chunk=4)
    assert not needs_shift(14, 0, 25, 100, rule)
    assert needs_shift(15, 0, 25, 100, rule)
    assert plan(15, 0, 25, 100, rule) == (4, 25)
    assert plan(91, 70, 95, 100, rule) == (80, 100)
    behind = [rule_for_accuracy(a).behind for a in (1e-3, 1e-6, 1e-8, 1e-9, 1e-10, 1e-12)]
    assert behind == sorted(behind) and behind[0] < behind[-1]  # tighter accuracy, never fewer beads
    thresholds = [rule_for_accuracy(a).threshold for a in (1e-3, 1e-6, 1e-8)]
    assert thresholds == sorted(thresholds, reverse=True) and all(t < a for t, a in zip(thresholds, (1e-3, 1e-6, 1e-8)))


def test_default_window_accuracy_follows_rtol():
    """None: the looser of rtol and 1e-8 (below 1e-3); a given accuracy wins."""
    assert window_accuracy_for(1e-10, None) == 1e-8 and window_accuracy_for(1e-6, None) == 1e-6
    assert window_accuracy_for(0.1, None) == 1e-3 and window_accuracy_for(1e-6, 1e-9) == 1e-9


def test_smallest_width_named_in_the_message_is_accepted():
    with pytest.raises(ValueError, match=f">= {MIN_WIDTH}"):
        resolve_rule(MIN_WIDTH - 1, 1e-8)
    rule = resolve_rule(MIN_WIDTH, 1e-8)
    assert rule.width == MIN_WIDTH and rule.behind >= 2


@pytest.mark.parametrize("window", ["big", 3, 16, WindowRule(behind=1), WindowRule(boundary="wall")])
def test_bad_window_arguments(window):
    with pytest.raises(ValueError, match="window"):
        resolve_rule(window, 1e-8)
    with pytest.raises(ValueError, match="window"):
        simulate(Chain(40, 1.5, 1.0), (1, 20), window=window)


def test_quintic_step_locates_an_analytic_maximum():
    """QuinticStep on x_1 = sin(t), x_2 = 0: delta_1 peaks at pi/2 with value 1."""
    from pulsemap.solvers.chain.peaks import QuinticStep

    def state(t):
        return np.array([np.sin(t), np.cos(t), 0.0, 0.0])

    def accel(t):
        return np.array([np.cos(t), -np.sin(t), 0.0, 0.0])

    calls = []

    def exact(t0, y0, f0, h):
        calls.append(h)
        return state(t0 + h)

    t0, t1 = 1.3, 1.9
    step = QuinticStep(t0, state(t0), accel(t0), t1, state(t1), accel(t1), exact)
    t, value = step.maximum(1)
    assert t == pytest.approx(np.pi / 2, abs=1e-9) and value == pytest.approx(1.0, abs=1e-14)
    assert len(calls) == 1 and abs(calls[0]) <= (t1 - t0) / 2  # one re-step from the nearer end
    assert np.allclose(step(1.5)[:2], state(1.5)[:2], atol=1e-5)  # the interpolant itself: ~h^6


def test_exact_stepper_is_the_method_order():
    """One DOP853 step of the window's scheme on y' = y: error ~h^9."""
    from pulsemap.solvers.chain.hairer import exact_stepper

    step = exact_stepper(lambda t, y: y, "DOP853")
    for h in (0.5, 0.25):
        y = step(0.0, np.array([1.0]), np.array([1.0]), h)
        assert abs(y[0] - np.exp(h)) < 3e-10 * (h / 0.5) ** 9
    rk45 = exact_stepper(lambda t, y: y, "RK45")
    assert abs(rk45(0.0, np.array([1.0]), np.array([1.0]), -0.1)[0] - np.exp(-0.1)) < 1e-8


def test_scene_force_is_restricted_to_the_window():
    """run.make_force gives restrict(): windowed scene DNS = full chain, O(window) force calls."""
    from pulsemap.solvers.studies.scene_chain import make_force
    from pulsemap.solvers.data.scene import load_scene

    scene = load_scene("fig8-eps0.1")
    force = make_force(scene, 80)
    part = force.restrict(20, 30)
    x, v = np.linspace(0.1, 0.2, 80), np.linspace(-1.0, 1.0, 80)
    assert np.allclose(part.force(x[20:30], v[20:30]), force.force(x, v)[20:30])
    assert np.allclose(part.dforce_dv(x[20:30], v[20:30]), force.dforce_dv(x, v)[20:30])
    full = simulate(Chain(80, 1.5, 1.0, force), (10, 60), integrator=TIGHT)
    win = simulate(Chain(80, 1.5, 1.0, force), (10, 60), integrator=TIGHT, window=WindowSpec(accuracy=1e-8))
    assert np.array_equal(full.alive, win.alive) and rel(win.peaks[win.alive], full.peaks[full.alive]) < 1e-8


@pytest.mark.parametrize("engine", ["compiled", "scipy"])
def test_windowed_chain_energy_only_without_R(engine):
    """With R the beads a window dropped go on losing energy out of sight: no total_energy then (the
    full chain has it); without R the window's count is the chain's energy (conserved)."""
    from pulsemap.solvers.data.scene import load_scene
    from pulsemap.solvers.studies.scene_chain import make_force

    scene = load_scene("fig8-eps0.1")
    force = make_force(scene, 140)
    kw = Integrator(rtol=1e-9, atol=1e-11, engine=engine)
    damped = simulate(Chain(140, 1.5, 1.0, force), (15, 45), integrator=kw, window="auto")
    full = simulate(Chain(140, 1.5, 1.0, force), (15, 45), integrator=kw)
    assert damped.total_energy is None and np.all(np.isfinite(damped.pulse_energy))
    assert np.all(np.diff(full.total_energy) < 0)  # damping: the chain loses energy
    free = simulate(Chain(140, 1.5, 1.0, None), (15, 45), integrator=kw, window="auto")
    assert np.allclose(free.total_energy, free.energy_initial, rtol=1e-6)
