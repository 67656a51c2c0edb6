"""DNS of paper Eq. 1: conservation, homogeneity, convergence, methods, peaks, guards."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pulsemap.solvers.chain.peaks import StopRules
from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.chain.equations import (
    DNSResult,
    OnSiteForce,
    band_pattern,
    chain_length_for,
    choose_method,
    energy,
    make_jacobians,
    make_rhs,
)
from pulsemap.solvers.chain.front import Snapshots
from pulsemap.solvers.chain.peaks import scan_step

FIRST_PERTURBED = 16


def damping(eps_mu: float, beads: int, first: int = FIRST_PERTURBED) -> OnSiteForce:
    """F = -eps*mu*v on beads >= first, with its analytic Jacobian."""
    mask = (np.arange(1, beads + 1) >= first).astype(float)
    return OnSiteForce(
        force=lambda x, v: -eps_mu * mask * v,
        dforce_dx=lambda x, v: np.zeros(beads),
        dforce_dv=lambda x, v: -eps_mu * mask,
        stiffness_hint=eps_mu,
    )


def rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(np.asarray(a) / np.asarray(b) - 1.0)))


# ----------------------------------------------------------------------------- unperturbed chain


@pytest.fixture(scope="module", params=[1.5, 3.0], ids=["n=1.5", "n=3"])
def unperturbed(request) -> tuple[float, DNSResult, DNSResult]:
    n = request.param
    beads = chain_length_for(40)
    slow = simulate(Chain(beads, n, 1.0), (1, 40))
    fast = simulate(Chain(beads, n, 4.0), (1, 40))
    return n, slow, fast


def test_unperturbed_finishes_with_all_contacts_alive(unperturbed):
    _, slow, fast = unperturbed
    for res in (slow, fast):
        assert res.stop_reason == "last contact peaked"
        assert res.alive.all() and np.isfinite(res.peaks).all()
        assert res.method == {"compiled": "RK45", "scipy": "DOP853"}[res.engine]
        assert list(res.contacts) == list(range(1, 41))


def test_energy_conserved(unperturbed):
    _, slow, fast = unperturbed
    assert slow.energy_drift is not None and slow.energy_drift < 3e-8
    assert fast.energy_drift < 3e-8


def test_energy_drift_shrinks_with_tolerance():
    loose = simulate(Chain(30, 1.5, 1.0), (1, 20), integrator=Integrator(rtol=1e-9, atol=1e-11))
    tight = simulate(Chain(30, 1.5, 1.0), (1, 20), integrator=Integrator(rtol=1e-12, atol=1e-14))
    assert tight.energy_drift < 1e-10
    assert tight.energy_drift < loose.energy_drift


def test_peaks_constant_after_formation(unperturbed):
    n, slow, _ = unperturbed
    formed = slow.peaks[24:40]  # contacts 25..40 (n = 1.5 forms within ~20 contacts)
    assert rel(formed, formed[5]) < 1e-6
    # ... but not before: the first contact is visibly above the formed wave
    assert slow.peaks[0] > formed[-1] * (1 + 1e-4)


def test_homogeneity_of_peaks(unperturbed):
    """Eq. 1 is homogeneous: peaks scale as v0^(2/(n+1)) contact by contact."""
    n, slow, fast = unperturbed
    ratio = 4.0 ** (2.0 / (n + 1.0))
    assert rel(fast.peaks / slow.peaks, ratio) < 1e-7


def test_homogeneity_of_delays(unperturbed):
    """Time scales as peak^(-s), s = (n-1)/2: the pulse delay between contacts follows."""
    n, slow, fast = unperturbed
    s = (n - 1.0) / 2.0
    d_slow = np.diff(slow.peak_times)[20:]
    d_fast = np.diff(fast.peak_times)[20:]
    expected = (fast.peaks[21:] / slow.peaks[21:]) ** (-s)
    assert rel(d_fast / d_slow, expected) < 1e-6
    assert rel(d_slow, d_slow[0]) < 1e-5  # constant speed of the formed wave


def test_two_tolerances_agree():
    beads = chain_length_for(30)
    loose = simulate(Chain(beads, 1.5, 1.0), (1, 30), integrator=Integrator(rtol=1e-8, atol=1e-10))
    tight = simulate(Chain(beads, 1.5, 1.0), (1, 30), integrator=Integrator(rtol=1e-11, atol=1e-13))
    assert rel(loose.peaks, tight.peaks) < 1e-6
    assert rel(np.diff(loose.peak_times), np.diff(tight.peak_times)) < 1e-6
    assert tight.nfev > loose.nfev  # the tighter run did more work


def test_peaks_are_leading_edge_not_roundoff(unperturbed):
    """Pre-arrival wiggles are never peaks: times increase, each delay is a pulse delay."""
    n, slow, _ = unperturbed
    delays = np.diff(slow.peak_times)
    assert np.all(delays > 0.5 * delays[-1])
    assert np.all(slow.peaks[1:] > 1e-2 * slow.peaks[:-1])
    assert slow.peak_times[0] > 0.5


def test_scan_step_skips_subthreshold_wiggle():
    """A + to - crossing of delta' whose maximum is round-off sized is not a peak."""
    beads = 4

    def state(t: float) -> np.ndarray:
        # delta_2 = 1e-15 sin(t): a wiggle with a maximum at t = pi/2
        y = np.zeros(2 * beads)
        y[2] = 1e-15 * np.sin(t)
        y[3] = 1e-15 * np.cos(t)
        return y

    args = (state(1.0), state(2.0), 1.0, 2.0, lambda: state)
    assert scan_step(*args, next_contact=2, last_contact=3, threshold=1e-3, fraction=1e-2) == []
    found = scan_step(*args, next_contact=2, last_contact=3, threshold=1e-16, fraction=1e-2)
    assert len(found) == 1 and found[0].contact == 2
    assert found[0].time == pytest.approx(np.pi / 2, abs=1e-12)
    assert found[0].value == pytest.approx(1e-15, rel=1e-12)


def test_noisy_rest_state_gives_no_early_peaks():
    """Beads ahead of the pulse oscillate at ~1e-10 (offset foundation): no peak is taken
    from that noise, whatever the acceptance fraction, and peak times stay ordered."""
    beads = 40
    offsets = np.random.default_rng(3).uniform(-1e-10, 1e-10, beads)
    noisy = OnSiteForce(lambda x, v: -0.05 * (x - offsets))
    clean = OnSiteForce(lambda x, v: -0.05 * x)
    ref = simulate(Chain(beads, 1.5, 1.0, clean), (1, 30))
    for fraction in (1e-2, 1e-300):
        res = simulate(Chain(beads, 1.5, 1.0, noisy), (1, 30), stop=StopRules(peak_fraction=fraction))
        assert res.alive.all()
        assert np.all(np.diff(res.peak_times) > 0.5)
        assert rel(res.peaks, ref.peaks) < 1e-6
        assert rel(res.peak_times, ref.peak_times) < 1e-6


# ----------------------------------------------------------------------------- damped chain


@pytest.fixture(scope="module")
def damped_reference() -> DNSResult:
    beads = chain_length_for(30)
    return simulate(Chain(beads, 1.5, 1.0, damping(0.3, beads)), (16, 30),
                    integrator=Integrator(method="DOP853", rtol=1e-9, engine="scipy"))


@pytest.mark.parametrize("method", ["Radau", "BDF", "LSODA", "RK45"])
def test_methods_agree_on_damped_chain(damped_reference, method):
    beads = damped_reference.beads
    res = simulate(Chain(beads, 1.5, 1.0, damping(0.3, beads)), (16, 30),
                   integrator=Integrator(method=method, rtol=1e-9))
    assert res.method == method
    assert res.alive.all() and damped_reference.alive.all()
    assert rel(res.peaks, damped_reference.peaks) < 1e-6
    if method in ("Radau", "BDF"):
        assert res.njev >= 1  # the analytic Jacobian was used (LSODA stays non-stiff here)


def test_finite_difference_jacobian_path_agrees(damped_reference):
    beads = damped_reference.beads
    f = damping(0.3, beads)
    no_jac = OnSiteForce(force=f.force, stiffness_hint=0.3)
    res = simulate(Chain(beads, 1.5, 1.0, no_jac), (16, 30), integrator=Integrator(method="LSODA", rtol=1e-9))
    assert rel(res.peaks, damped_reference.peaks) < 1e-6


def test_damped_peaks_decrease_and_pulse_dies():
    beads = chain_length_for(50)
    res = simulate(Chain(beads, 1.5, 1.0, damping(0.3, beads)), (16, 50))
    live = res.peaks[res.alive]
    assert len(live) > 10
    assert np.all(np.diff(live) < 0)
    # at v0 = 1 this pulse stops advancing a few tens of contacts in (docs/figures.rst, "How close is the map?": many pulses die)
    assert res.stop_reason.startswith("pulse died")
    assert not res.alive[-1] and np.isnan(res.peaks[-1])
    dead = ~res.alive
    assert np.all(dead[np.argmax(dead):])  # once dead, dead for good


def test_amplitude_death_keeps_the_dying_peak():
    """A peak below death_fraction x the first requested peak ends the run at that contact."""
    beads = chain_length_for(40)
    res = simulate(Chain(beads, 1.5, 1.0, damping(0.3, beads)), (16, 40), stop=StopRules(death_fraction=0.5))
    assert res.stop_reason.startswith("pulse died at contact")
    k = int(res.stop_reason.split()[4])
    i = k - 16
    assert res.peaks[i] < 0.5 * res.peaks[0] <= res.peaks[i - 1]
    assert res.alive[:i].all() and not res.alive[i:].any()
    assert np.isfinite(res.peaks[: i + 1]).all() and np.isnan(res.peaks[i + 1 :]).all()


def test_strong_damping_finishes_quickly_with_implicit_method():
    beads = chain_length_for(45)
    res = simulate(Chain(beads, 1.5, 1.0, damping(100.0, beads)), (16, 45))
    assert res.method in ("Radau", "BDF", "LSODA")
    assert res.stop_reason.startswith("pulse died")
    assert res.alive.sum() <= 1 and not res.alive[1:].any()
    assert np.isnan(res.peaks[1:]).all()
    assert res.wall_time_s < 5.0
    assert res.nfev < 50_000
    assert res.njev >= 1  # stiff: the banded analytic Jacobian was used
    explicit = simulate(Chain(beads, 1.5, 1.0, damping(100.0, beads)), (16, 45),
                        integrator=Integrator(method="DOP853", engine="scipy"))
    assert explicit.stop_reason.startswith("pulse died")
    assert res.peaks[0] == pytest.approx(explicit.peaks[0], rel=1e-6)


def test_auto_method_choice():
    assert choose_method(None, 1.0, 1.5) == "DOP853"
    assert choose_method(damping(0.3, 20), 1.0, 1.5) == "DOP853"
    assert choose_method(damping(1e4, 20), 1.0, 1.5) == "LSODA"


# ----------------------------------------------------------------------------- building blocks


def test_rhs_matches_eq1_on_three_beads():
    x = np.array([0.3, 0.1, 0.2])
    v = np.array([1.0, -0.5, 0.25])
    y = np.ravel(np.column_stack([x, v]))
    out = make_rhs(3, 1.5, None)(0.0, y)
    assert np.allclose(out[0::2], v)
    assert np.allclose(out[1::2], [-(0.2**1.5), 0.2**1.5, 0.0])  # contact 2 is open


@pytest.mark.parametrize("window", [False, True])
def test_jacobians_match_finite_differences(window):
    """Whole chain, and a window: prescribed left bead compressing bead 1, last bead against the wall."""
    rng = np.random.default_rng(1)
    beads = 9
    f = OnSiteForce(
        force=lambda x, v: -0.7 * v - 0.4 * x**3,
        dforce_dx=lambda x, v: -1.2 * x**2,
        dforce_dv=lambda x, v: -0.7 * np.ones_like(v),
    )
    y = rng.normal(scale=0.5, size=2 * beads)
    bounds = {}
    if window:
        y[0], y[-2] = -0.2, 0.4
        bounds = dict(left=lambda t: 0.9, wall=True)
    rhs = make_rhs(beads, 1.5, f, **bounds)
    h = 1e-7
    fd = np.column_stack([(rhs(0, y + h * e) - rhs(0, y - h * e)) / (2 * h) for e in np.eye(2 * beads)])
    sparse_jac, packed_jac = make_jacobians(beads, 1.5, f, **bounds)
    sp = sparse_jac(0.0, y).toarray()
    assert np.allclose(sp, fd, atol=1e-6)
    assert np.all((band_pattern(beads).toarray() != 0) | (fd == 0))
    packed = packed_jac(0.0, y)
    unpacked = np.zeros_like(fd)
    for i in range(2 * beads):
        for j in range(max(0, i - 3), min(2 * beads, i + 2)):
            unpacked[i, j] = packed[1 + i - j, j]
    assert np.allclose(unpacked, sp)


def test_energy_and_chain_length():
    assert energy(np.array([0.0, 0.0]), np.array([2.0, 0.0]), 1.5) == pytest.approx(2.0)
    assert energy(np.array([1.0, 0.0]), np.zeros(2), 3.0) == pytest.approx(0.25)
    assert energy(np.array([0.0, 1.0]), np.zeros(2), 3.0) == 0.0  # open contact stores nothing
    assert chain_length_for(120) == 131
    assert chain_length_for(120, margin=0) == 121


# ----------------------------------------------------------------------------- guards and errors


def test_energy_blowup_stops_run():
    res = simulate(Chain(20, 1.5, 1.0, OnSiteForce(lambda x, v: 5.0 * v)), (1, 9))
    assert "energy grew" in res.stop_reason
    assert not res.alive.any() and np.isnan(res.peaks).all()


def test_nonfinite_force_stops_run():
    res = simulate(Chain(20, 1.5, 1.0, OnSiteForce(lambda x, v: np.where(np.abs(x) > 0.5, np.nan, 0.0))), (1, 9))
    assert "non-finite" in res.stop_reason or "integrator failed" in res.stop_reason
    assert res.alive.sum() < 9


def test_t_max_keeps_measured_peaks():
    res = simulate(Chain(20, 1.5, 1.0), (1, 9), stop=StopRules(t_max=3.0))
    assert res.stop_reason.startswith("t_max reached")
    assert res.alive[:2].all() and not res.alive[2:].any()
    assert np.isnan(res.peaks[2:]).all() and np.isfinite(res.peaks[:2]).all()


def test_reports_only_requested_range():
    res = simulate(Chain(30, 1.5, 1.0), (10, 12))
    full = simulate(Chain(30, 1.5, 1.0), (1, 12))
    assert list(res.contacts) == [10, 11, 12]
    assert np.array_equal(res.peaks, full.peaks[9:])


@pytest.mark.parametrize(
    "kwargs, pattern",
    [
        (dict(beads=1), "beads"),
        (dict(beads=10.5), "beads"),
        (dict(exponent=1.0), "exponent"),
        (dict(exponent=float("nan")), "exponent"),
        (dict(velocity=float("inf")), "velocity"),
        (dict(velocity=0.0), "velocity"),
        (dict(velocity=-1.0), "velocity"),
        (dict(velocity=10**400), "velocity is beyond the float range"),
        (dict(exponent=10**400), "exponent is beyond the float range"),
        (dict(t_max=10**400), "t_max is beyond the float range"),
        (dict(contacts=(0, 5)), "contacts"),
        (dict(contacts=(5, 20)), "contacts"),
        (dict(contacts=(6, 5)), "contacts"),
        (dict(contacts=(1.5, 5)), "contacts"),
        (dict(contacts=5), "contacts"),
        (dict(rtol=0.0), "rtol"),
        (dict(atol=-1.0), "atol"),
        (dict(method="Euler"), "method"),
        (dict(peak_fraction=1.5), "peak_fraction"),
        (dict(death_fraction=-0.1), "death_fraction"),
        (dict(t_max=-1.0), "t_max"),
        (dict(stall_factor=0.5), "stall_factor"),
    ],
)
def test_bad_arguments(kwargs, pattern):
    args = dict(beads=20, exponent=1.5, velocity=1.0, contacts=(1, 5))
    args.update(kwargs)
    stop = {k: args.pop(k) for k in ("peak_fraction", "death_fraction", "t_max", "stall_factor") if k in args}
    integrator = {k: args.pop(k) for k in ("method", "rtol", "atol") if k in args}
    with pytest.raises(ValueError, match=pattern):
        simulate(Chain(args.pop("beads"), args.pop("exponent"), args.pop("velocity")), args.pop("contacts"),
                 integrator=Integrator(**integrator), stop=StopRules(**stop))


@pytest.mark.slow
@pytest.mark.parametrize("method", ["LSODA", "BDF", "Radau"])
def test_long_chain_methods_agree(method):
    """140 beads to contact 120 (the paper's chain), implicit vs DOP853 at rtol 1e-10."""
    ref = simulate(Chain(140, 1.5, 1.0), (1, 120), integrator=Integrator(method="DOP853", engine="scipy"))
    res = simulate(Chain(140, 1.5, 1.0), (1, 120), integrator=Integrator(method=method))
    assert res.alive.all() and rel(res.peaks, ref.peaks) < 1e-6
    assert res.energy_drift < 1e-6


# ----------------------------------------------------------------------------- blow-up guard


def unstable(k: float, beads: int, velocity_term: bool = False, first: int = FIRST_PERTURBED) -> OnSiteForce:
    """R = +k*u (unstable foundation) or R = +k*v (negative damping) from bead ``first``."""
    mask = (np.arange(1, beads + 1) >= first).astype(float)
    if velocity_term:
        return OnSiteForce(lambda x, v: k * mask * v, lambda x, v: np.zeros(beads), lambda x, v: k * mask)
    return OnSiteForce(lambda x, v: k * mask * x, lambda x, v: k * mask, lambda x, v: np.zeros(beads))


@pytest.mark.parametrize("window", [None, "auto"])
@pytest.mark.parametrize("velocity_term", [False, True], ids=["R=+k*u", "R=+k*v"])
def test_blow_up_stops_with_reason_and_keeps_measured_peaks(window, velocity_term):
    beads = chain_length_for(60)
    force = unstable(200.0, beads, velocity_term)
    res = simulate(Chain(beads, 1.5, 1.0, force), (1, 60), window=window)
    clean = simulate(Chain(beads, 1.5, 1.0), (1, 15), window=window)
    assert res.blew_up and res.stop_reason.startswith("blow-up")
    assert "energy grew" in res.stop_reason or "non-finite" in res.stop_reason
    # the precursor ahead of the pulse is amplified as soon as it reaches bead 16, so the run
    # stops before the pulse gets there; the peaks measured before that are kept, unchanged
    kept = int(res.alive.sum())
    assert kept >= 5 and res.alive[:kept].all() and not res.alive[kept:].any()
    assert np.isfinite(res.peaks[:kept]).all() and np.isnan(res.peaks[kept:]).all()
    assert rel(res.peaks[:5], clean.peaks[:5]) < 1e-7
    assert res.steps < 5000  # stopped promptly, not at the step budget or t_max


def test_step_budget_bounds_a_run():
    res = simulate(Chain(60, 1.5, 1.0), (1, 50), integrator=Integrator(engine="scipy"), stop=StopRules(max_steps=40))
    assert res.stop_reason.startswith("step budget of 40 steps")
    assert res.steps == 40 and not res.blew_up
    assert 0 < res.alive.sum() < 50 and np.isfinite(res.peaks[res.alive]).all()
    win = simulate(Chain(60, 1.5, 1.0), (1, 50), stop=StopRules(max_steps=40), window="auto")
    assert win.stop_reason.startswith("step budget")


def test_default_step_budget_scales_with_the_run_length_and_the_tolerance():
    """STEPS_PER_CONTACT per contact to the last, more per contact below BUDGET_RTOL as rtol^(-1/4)."""
    from pulsemap.solvers.chain.equations import BUDGET_RTOL, STEPS_PER_CONTACT, default_max_steps

    assert default_max_steps(30) == STEPS_PER_CONTACT * 40 == default_max_steps(30, 1e-6)
    assert default_max_steps(90) == 2 * default_max_steps(40)
    tight = default_max_steps(30, BUDGET_RTOL / 100)
    assert tight == pytest.approx(10 ** 0.5 * default_max_steps(30), rel=1e-5)
    res = simulate(Chain(60, 1.5, 1.0), (1, 8), integrator=Integrator(engine="scipy", rtol=1e-12, atol=1e-14),
                   stop=StopRules(max_steps=None))
    assert res.stop_reason == "last contact peaked" and res.steps < default_max_steps(8, 1e-12)


@pytest.mark.parametrize("bad", [0, -3, 2.5, True])
def test_bad_step_budget(bad):
    with pytest.raises(ValueError, match="max_steps"):
        simulate(Chain(20, 1.5, 1.0), (1, 5), stop=StopRules(max_steps=bad))


def test_run_output_of_an_unstable_scene_has_a_warning_and_no_nan(tmp_path):
    import json

    from pulsemap.solvers.studies.run import run_scene
    from pulsemap.solvers.data.scene import load_scene

    path = tmp_path / "unstable.toml"
    path.write_text('name = "unstable"\n[chain]\nexponent = 1.5\nfirst_perturbed = 16\n[excitation]\n'
                    'velocity = 1.0\n[perturbation]\nR = "k*u"\neps = 0.1\n[perturbation.params]\nk = 100.0\n'
                    '[output]\ncontacts = [16, 60]\nmethods = ["dns"]\n')
    for window in (None, "auto"):
        out = run_scene(load_scene(str(path)), dns_window=window)
        assert out["dns"]["stop_reason"].startswith("blow-up")
        assert any("blow-up" in w for w in out["warnings"])
        json.dumps(out, allow_nan=False)  # raises on NaN/inf anywhere
        assert all(p is None for p in out["peaks"]["dns"][5:])


def test_run_specs_are_frozen_values_checked_when_made():
    """Chain, Integrator and Snapshots normalise what they hold, compare by value and refuse edits."""
    chain = Chain(np.int64(40), 2, 1)
    assert type(chain.beads) is int and type(chain.exponent) is float and type(chain.velocity) is float
    assert chain == Chain(40, 2.0, 1.0) and hash(chain) == hash(Chain(40, 2.0, 1.0))
    with pytest.raises(dataclasses.FrozenInstanceError):
        chain.beads = 50
    assert Snapshots([30, 20], span=[1, 2]) == Snapshots((30, 20), (1, 2))
    assert Integrator() == Integrator("auto", 1e-10, 1e-12, "compiled")
    with pytest.raises(ValueError, match="unknown engine 'numba'"):
        Integrator(engine="numba")
    with pytest.raises(TypeError, match="launch must be"):
        Chain(40, 1.5, 1.0, launch=(0.7, 8))


def test_the_ends_of_the_option_ranges_still_run():
    """The ranges the option objects enforce refuse only what no run can use: rtol just below 1 and the
    largest exponent give finite peaks."""
    loose = simulate(Chain(40, 1.5, 1.0), (5, 30), integrator=Integrator(rtol=0.99)).peaks
    assert np.all(np.isfinite(loose[:10]))
    steep = simulate(Chain(40, 20.0, 1.0), (5, 30)).peaks
    assert np.all(np.isfinite(steep)) and np.all(steep > 0)
