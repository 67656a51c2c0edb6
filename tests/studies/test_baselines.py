"""Baseline (a) of the DNS benchmark: the loop-RHS + solve_ivp + sampled-grid script."""

from __future__ import annotations

import numpy as np
import pytest

from pulsemap.solvers.studies.bench.baselines import baseline_script, first_maximum, script_rhs
from pulsemap.solvers.chain.dns import Chain, make_rhs, simulate


def test_script_rhs_is_eq1():
    rng = np.random.default_rng(0)
    beads = 7
    x, v = rng.normal(size=beads), rng.normal(size=beads)
    ours = make_rhs(beads, 1.5, None)(0.0, np.ravel(np.column_stack([x, v])))
    theirs = script_rhs(beads, 1.5, None)(0.0, np.concatenate([x, v]))
    assert np.allclose(theirs[:beads], ours[0::2]) and np.allclose(theirs[beads:], ours[1::2])


def test_baseline_peaks_agree_with_simulate_to_sampling_accuracy():
    ref = simulate(Chain(40, 1.5, 1.0), (1, 30))
    res = baseline_script(40, 1.5, 1.0, (1, 30), dt_sample=0.01)
    assert res.alive.all()
    assert np.max(np.abs(res.peaks / ref.peaks - 1)) < 1e-3
    assert np.max(np.abs(res.peak_times - ref.peak_times)) <= 0.01
    coarse = baseline_script(40, 1.5, 1.0, (1, 30), dt_sample=0.1)
    assert np.max(np.abs(coarse.peaks / ref.peaks - 1)) > np.max(np.abs(res.peaks / ref.peaks - 1))


def test_baseline_damped_chain():
    eps_mu = 0.05
    mask = (np.arange(1, 41) >= 16).astype(float)
    from pulsemap.solvers.chain.dns import OnSiteForce

    ref = simulate(Chain(40, 1.5, 1.0, OnSiteForce(lambda x, v: -eps_mu * mask * v)), (16, 30))
    res = baseline_script(40, 1.5, 1.0, (16, 30), lambda i, x, v: -eps_mu * v if i >= 16 else 0.0,
                          t_end=ref.peak_times[-1] + 3.0)
    assert res.alive.all()
    assert np.max(np.abs(res.peaks / ref.peaks - 1)) < 1e-3


def test_first_maximum_takes_the_first_maximum_above_threshold_after_the_floor():
    t = np.linspace(0, 10, 1001)
    d = np.exp(-(t - 2) ** 2) + 1e-6 * np.sin(40 * t) + 0.5 * np.exp(-(t - 6) ** 2)
    j = first_maximum(d, t, 1e-2, -np.inf)  # the ripple's maxima before t = 2 lie below the threshold
    assert t[j] == pytest.approx(2.0, abs=0.02)
    later = first_maximum(d, t, 1e-2, t[j] + 1.0)
    assert t[later] == pytest.approx(6.0, abs=0.02) and d[later] == pytest.approx(0.5, rel=1e-3)
    assert first_maximum(d, t, 2.0, -np.inf) is None


def test_segmented_script_reads_the_same_grid_peaks():
    """Integrating in segments (memory-bounded) gives the one-call script's peaks."""
    one = baseline_script(40, 1.5, 1.0, (1, 30), dt_sample=0.01)
    seg = baseline_script(40, 1.5, 1.0, (1, 30), dt_sample=0.01, segment_samples=700)
    assert seg.alive.all() and np.array_equal(one.peak_times, seg.peak_times)
    assert np.max(np.abs(seg.peaks / one.peaks - 1)) < 1e-6  # restarts change RK45's steps slightly
