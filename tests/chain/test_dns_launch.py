"""dns.simulate from an exact-soliton launch (chain/launch.Launch): the wave travels unchanged in the full
chain and the moving window; bad launches refused."""

from __future__ import annotations

import numpy as np
import pytest

from pulsemap.symbolic.profile import exact_profile
from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.chain.launch import Launch


@pytest.mark.parametrize("engine", ["compiled", "scipy"])
@pytest.mark.parametrize("window", [None, "auto"])
@pytest.mark.parametrize("amplitude", [0.01, 1.0, 37.0])
def test_launched_wave_keeps_its_peak_and_speed(window, amplitude, engine):
    """Unperturbed chain: every peak is A S(0) and contact k peaks at (k - c) A^(-s) (Eq. 32), on both engines."""
    n = 1.5
    res = simulate(Chain(50, n, 1.0, launch=Launch(amplitude, 8)), (9, 40),
                   integrator=Integrator(engine=engine), window=window)
    assert res.engine == engine
    assert np.all(res.alive) and res.stop_reason == "last contact peaked"
    assert res.energy_drift < 1e-7  # the launched wave's energy (the window's share) is kept
    S0 = exact_profile(n).S0
    assert np.max(np.abs(res.peaks / (amplitude * S0) - 1.0)) < 1e-8
    expected = (res.contacts - 8) * amplitude ** (-(n - 1) / 2)
    assert np.max(np.abs(res.peak_times / expected - 1.0)) < 1e-8


@pytest.mark.parametrize("R, stiff", [("-mu*v", False), ("-mu*u**3", False), ("-mu*v", True)])
def test_a_launch_into_a_perturbed_chain_agrees_on_both_engines(R, stiff):
    """A launched wave entering a perturbed segment (the relaxed map's segment runs): the compiled engine
    (explicit, or Rodas4 when stiff) gives the scipy engine's peaks within the tolerances, same live range."""
    from pulsemap.solvers.data.scene.overrides import with_sets
    from pulsemap.solvers.data.scene import load_scene
    from pulsemap.solvers.studies.scene_chain import make_force

    beads, centre, first = 60, 8, 14
    scene = with_sets(load_scene("fig8-eps0.1"), [f"perturbation.R={R}", f"perturbation.params.mu={1000.0 if stiff else 0.3}",
                                                   "perturbation.eps=1.0", f"chain.first_perturbed={first}"])
    force = make_force(scene, beads)
    chain = Chain(beads, 1.5, 1.0, force, launch=Launch(0.7, centre))
    fast = simulate(chain, (centre + 1, 45), window="auto", integrator=Integrator(rtol=1e-10, atol=1e-13))
    ref = simulate(chain, (centre + 1, 45),
                   window="auto", integrator=Integrator(engine="scipy", rtol=1e-10, atol=1e-13))
    assert fast.engine == "compiled" and ref.engine == "scipy"
    assert fast.method == ("Rodas4" if stiff else "RK45")
    assert np.array_equal(fast.alive, ref.alive) and fast.alive.sum() >= 2
    assert np.max(np.abs(fast.peaks[fast.alive] / ref.peaks[ref.alive] - 1.0)) < 1e-6


def test_launch_state_is_the_travelling_wave():
    """Strains are A S(c - i); the velocities are the time derivative of the displacements."""
    n, A, c = 1.5, 2.0, 8
    y = Launch(A, c).state(n, 30)
    x, v = y[0::2], y[1::2]
    prof = exact_profile(n)
    j = np.arange(1, 30)
    assert np.allclose(x[:-1] - x[1:], A * prof.S(c - j), atol=1e-15, rtol=0)
    # d/dt of x_i(t) = sum_{j>=i} A S(A^s t - j + c) at t = 0, by a centred difference of the wave
    s, h = (n - 1) / 2, 1e-5
    def xs(t):
        d = A * prof.S(A ** s * t - np.arange(1, 31) + c)
        return np.cumsum(d[::-1])[::-1]
    assert np.allclose(v, (xs(h) - xs(-h)) / (2 * h), atol=1e-8, rtol=0)
    assert abs(v[0]) < 1e-12 and abs(x[0] - x[1]) < 1e-14  # the free end behind the wave is at rest (round-off)


@pytest.mark.parametrize("launch, contacts, beads, words", [
    (Launch(1.0, 3), (8, 20), 40, "tail"),
    (Launch(1.0, 8), (8, 20), 40, "after it"),
    (Launch(1.0, 8), (9, 12), 16, "beads >="),
])
def test_bad_launch_is_refused(launch, contacts, beads, words):
    with pytest.raises(ValueError, match=words):
        simulate(Chain(beads, 1.5, 1.0, launch=launch), contacts)


@pytest.mark.parametrize("amplitude, centre", [(0.0, 7), (float("nan"), 7), (1.0, 0), (1.0, 2.5)])
def test_bad_launch_values(amplitude, centre):
    with pytest.raises(ValueError, match="launch"):
        Launch(amplitude, centre)


def test_launch_must_be_a_launch():
    with pytest.raises(TypeError, match="launch"):
        simulate(Chain(40, 1.5, 1.0, launch=(1.0, 8)), (9, 20))
