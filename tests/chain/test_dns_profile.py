"""The DNS against the profile: pulse speed and shape of the unperturbed chain (Eqs. 4, 6, 32)."""

import numpy as np
import pytest

from pulsemap.symbolic.profile import exact_profile
from pulsemap.solvers.chain.dns import Chain, Integrator, simulate


@pytest.mark.parametrize("n", [1.5, 2.5])
def test_unperturbed_pulse_speed_and_peak_match_the_profile(n):
    """Delay between contacts = A^(-s) with A = peak / S(0) (erratum 4, docs/errata.rst: not Eq. 6 as printed)."""
    res = simulate(Chain(50, n, 1.0), (25, 40), integrator=Integrator(rtol=1e-11, atol=1e-13))
    s = (n - 1) / 2
    S0 = exact_profile(n).S0
    A = res.peaks / S0
    delays = np.diff(res.peak_times)
    assert delays == pytest.approx(A[1:] ** -s, rel=2e-6)
    # the printed Eq. 6, T = S(0)^(1/4) A^(-1/4) with this A, is off by S(0)^(s) (n = 3/2: 10 %)
    assert abs(delays[0] / (S0**s * A[1] ** -s) - 1) > 0.05


def test_dns_strain_follows_the_travelling_wave_shape():
    """delta_i(t) near the peak equals A S(A^s (t - T_i)) of the exact profile."""
    from pulsemap.solvers.chain.dns import make_rhs, initial_state
    from scipy.integrate import solve_ivp

    n, beads = 1.5, 40
    res = simulate(Chain(beads, n, 1.0), (29, 31), integrator=Integrator(rtol=1e-11, atol=1e-13))
    p = exact_profile(n)
    A = res.peaks[1] / p.S0
    T = res.peak_times[1]
    sol = solve_ivp(make_rhs(beads, n, None), (0, T + 2), initial_state(beads, 1.0), method="DOP853",
                    rtol=1e-11, atol=1e-13, dense_output=True)
    t = np.linspace(T - 1.5 * A**-0.25, T, 50)
    y = sol.sol(t)
    strain = y[2 * 29] - y[2 * 30]  # contact 30 = beads 30, 31 (interleaved state: x at even index)
    model = A * p.S(A**0.25 * (t - T))
    dev = np.max(np.abs(strain - model)) / res.peaks[1]
    print(f"leading-edge shape deviation {dev:.2e}")
    assert dev < 1e-7


def test_overtake_predicate():
    from pulsemap.solvers.chain.peaks import primary_pulse_lost

    peaks = np.array([1.0, 0.9, 0.8, 0.85, 1.2, 0.0005])
    assert primary_pulse_lost(peaks, 4, 1, 1e-3, 1.25) == ""  # +6 %: an eps-small change
    assert "overtook" in primary_pulse_lost(peaks, 5, 1, 1e-3, 1.25)  # +41 %
    assert "below" in primary_pulse_lost(peaks, 6, 1, 1e-3, 1.25)
    assert primary_pulse_lost(peaks, 5, 5, 1e-3, 1.25) == ""  # the first contact has no predecessor


def test_wake_overtaking_a_dying_pulse_ends_the_primary_pulse():
    """Linear foundation (paper Fig. 6, eps = 0.1): the pulse fades, the wake arrives first."""
    from pulsemap.solvers.studies.scene_chain import make_force
    from pulsemap.solvers.data.scene import load_scene

    sc = load_scene("fig6-eps0.1")
    res = simulate(Chain(131, 1.5, 1.0, make_force(sc, 131)), (15, 120))
    assert "overtook" in res.stop_reason
    live = res.peaks[res.alive]
    assert 20 < live.size < 60
    assert np.all(np.diff(live) < 0)  # the foundation drains the pulse: monotone decay while alive
    assert not res.alive[-1]


def test_delay_jump_ends_the_primary_pulse():
    from pulsemap.solvers.chain.peaks import primary_pulse_lost

    peaks = np.array([1.0, 0.8, 0.6, 0.5])
    times = np.array([0.0, 1.0, 2.1, 6.0])
    assert primary_pulse_lost(peaks, 3, 1, 1e-3, 1.25, times) == ""  # 1.1 after 1.0
    assert "solitary" in primary_pulse_lost(peaks, 4, 1, 1e-3, 1.25, times)  # 3.9 after 1.1


def test_strong_damping_stops_at_the_end_of_the_solitary_front():
    """eps mu = 1 (Fig. 8, eps = 1): a slow compression follows the pulse; it is not the pulse."""
    from pulsemap.solvers.studies.scene_chain import make_force
    from pulsemap.solvers.data.scene import load_scene

    sc = load_scene("fig8-eps1")
    res = simulate(Chain(131, 1.5, 1.0, make_force(sc, 131)), (15, 120))
    assert "solitary" in res.stop_reason
    assert res.alive.sum() < 15 and res.t_end < 100
