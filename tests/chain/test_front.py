"""Front diagnostics of the DNS (solvers/chain/front.py): pulse energy, total energy, speed, snapshots.

Checked against the solitary wave delta_k(t) = A S(A^s t - k) of the unperturbed chain, computed
independently (derive/profile.py, derive/balance.py), and against conservation of energy.
"""

from __future__ import annotations

import numpy as np
import pytest

from pulsemap.symbolic.balance import balance_constants
from pulsemap.symbolic.profile import exact_profile
from pulsemap.solvers.chain.front import Snapshots
from pulsemap.solvers.chain.dns import Chain, simulate
from pulsemap.solvers.chain.equations import OnSiteForce, chain_length_for
from pulsemap.solvers.chain.front import pulse_speed

N = 1.5
FIRST, LAST = 20, 50


@pytest.fixture(scope="module")
def unperturbed():
    return simulate(Chain(chain_length_for(LAST), N, 1.0), (FIRST, LAST), snapshots=Snapshots([30, LAST]))


@pytest.fixture(scope="module")
def wave_amplitude(unperturbed):
    return float(np.mean(unperturbed.peaks)) / exact_profile(N).S0


def test_pulse_energy_is_the_solitary_waves(unperturbed, wave_amplitude):
    """E_1 A^(n+1) with E_1 = K_1 + V_1 integrated over the profile (mpmath), A = peak / S(0)."""
    c = balance_constants(["K1", "V1"], n=N)
    E1 = c["K1"].value + c["V1"].value
    assert np.isfinite(unperturbed.pulse_energy).all()
    A = unperturbed.peaks / exact_profile(N).S0
    formed = unperturbed.contacts >= 35  # before, the wave is still shedding its wake (peaks settle by 1e-5)
    assert unperturbed.pulse_energy[formed] == pytest.approx(E1 * A[formed] ** (N + 1), rel=1e-7)
    assert unperturbed.pulse_energy == pytest.approx(E1 * A ** (N + 1), rel=1e-5)
    assert unperturbed.pulse_energy.max() < unperturbed.energy_initial  # the wake keeps a little


def test_total_energy_is_conserved_without_r(unperturbed):
    assert unperturbed.energy_initial == pytest.approx(0.5, rel=1e-15)  # v0^2/2
    assert unperturbed.total_energy == pytest.approx(0.5, rel=1e-7)
    assert unperturbed.energy_drift is not None and unperturbed.energy_drift < 1e-7


def test_speed_is_a_to_the_s(unperturbed, wave_amplitude):
    """delta_k(t) = A S(A^s t - k): contact k peaks at t = k / A^s + const."""
    s = (N - 1) / 2
    A = unperturbed.peaks / exact_profile(N).S0
    assert unperturbed.speed == pytest.approx(A ** s, rel=1e-6)


def test_snapshot_is_the_profile_around_the_peak(unperturbed, wave_amplitude):
    """At the time contact k peaks, delta_j = A S(k - j)."""
    profile = exact_profile(N)
    snaps = {s.contact: s for s in unperturbed.snapshots}
    assert set(snaps) == {30, LAST}
    snap = snaps[30]
    j = np.arange(snap.first_contact, snap.first_contact + len(snap.strains))
    assert j[0] == 30 - 12 and j[-1] == 30 + 4
    assert snap.time == pytest.approx(unperturbed.peak_times[30 - FIRST], rel=1e-14)
    assert snap.strains[j == 30][0] == pytest.approx(unperturbed.peaks[30 - FIRST], rel=1e-12)
    expected = wave_amplitude * np.array([profile.S(float(30 - jj)) for jj in j])
    near = np.abs(j - 30) <= 2
    assert snap.strains[near] == pytest.approx(expected[near], rel=1e-5, abs=1e-7)
    assert snaps[LAST].first_contact + len(snaps[LAST].strains) - 1 <= LAST + 4
    assert snaps[LAST].as_dict()["contacts"][0] == LAST - 12


def test_window_records_the_same_front():
    full = simulate(Chain(chain_length_for(60), N, 1.0), (20, 60), snapshots=Snapshots([40]))
    win = simulate(Chain(chain_length_for(60), N, 1.0), (20, 60), snapshots=Snapshots([40]), window="auto")
    assert win.mode.startswith("window")
    assert win.pulse_energy == pytest.approx(full.pulse_energy, rel=1e-7)
    assert win.total_energy == pytest.approx(full.total_energy, rel=1e-6)
    assert win.snapshots[0].strains == pytest.approx(full.snapshots[0].strains, rel=1e-5, abs=1e-9)


def test_damping_drains_the_pulse_and_the_chain():
    beads = chain_length_for(40)
    mask = (np.arange(1, beads + 1) >= 16).astype(float)
    force = OnSiteForce(force=lambda x, v: -0.1 * mask * v)
    res = simulate(Chain(beads, N, 1.0, force), (16, 40))
    live = res.alive & np.isfinite(res.pulse_energy)
    assert live.sum() > 5
    assert np.all(np.diff(res.total_energy[live]) < 0)  # work of -mu v is negative
    assert np.all(np.diff(res.pulse_energy[live]) < 0)
    assert np.all(res.pulse_energy[live] < res.total_energy[live])
    assert res.energy_drift is None  # not conserved with R: no drift to report


def test_pulse_speed_of_a_partial_run():
    t = np.array([1.0, 2.0, 3.5, np.nan, np.nan])
    v = pulse_speed(t)
    assert v[:3] == pytest.approx([1.0, 1 / 1.25, 1 / 1.5])
    assert np.isnan(v[3:]).all()
    assert np.isnan(pulse_speed(np.array([1.0]))).all()


@pytest.mark.parametrize("kwargs, pattern", [
    ({"contacts": [5]}, "snapshot contact 5"),
    ({"contacts": [2.5]}, "snapshot contact"),
    ({"span": (-1, 2)}, "snapshot span"),
])
def test_bad_snapshot_arguments(kwargs, pattern):
    with pytest.raises(ValueError, match=pattern):
        simulate(Chain(chain_length_for(30), N, 1.0), (20, 30), snapshots=Snapshots(**kwargs))
