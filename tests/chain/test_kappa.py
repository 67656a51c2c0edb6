"""kappa_n: formed solitary-wave peak per v0^(2/(n+1)), measured by DNS and cached."""

from __future__ import annotations

import numpy as np
import pytest

import pulsemap.solvers.chain.kappa as kappa_mod
from pulsemap.solvers.chain.dns import Chain, chain_length_for, simulate
from pulsemap.solvers.chain.kappa import kappa, peak_from_velocity, velocity_from_peak


@pytest.fixture(autouse=True)
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("PULSEMAP_CACHE_DIR", str(tmp_path))


@pytest.mark.parametrize("n", [1.5, 3.0])
def test_peak_from_velocity_matches_direct_dns(n):
    v0 = 2.3
    res = simulate(Chain(chain_length_for(35), n, v0), (25, 35))
    assert res.alive.all()
    assert peak_from_velocity(v0, n) == pytest.approx(res.peaks[5], rel=1e-6)


def test_velocity_from_peak_inverts():
    for v0 in (0.1, 1.0, 7.0):
        assert velocity_from_peak(peak_from_velocity(v0, 1.5), 1.5) == pytest.approx(v0, rel=1e-12)


def test_kappa_is_cached(monkeypatch):
    first = kappa(1.5)
    monkeypatch.setattr(kappa_mod, "measure_kappa", lambda *a, **k: pytest.fail("cache missed"))
    assert kappa(1.5) == first
    assert 0.5 < first < 1.0


def test_cache_key_names_its_inputs():
    key = kappa_mod.cache_key(1.5, 1e-10)
    assert "n=1.5" in key and "rtol=1e-10" in key and "contact=30" in key
    assert kappa_mod.cache_key(1.5, 1e-9) != key and kappa_mod.cache_key(2.5, 1e-10) != key


def test_slow_formation_moves_measurement_down_the_chain():
    """Near n = 1 the wave forms slowly; the measurement contact is doubled until it has."""
    entry = kappa_mod.measure_kappa(1.2)
    assert entry["contact"] > 30 and entry["spread"] <= 1e-6


@pytest.mark.parametrize("bad", [dict(exponent=1.0), dict(exponent=float("nan"))])
def test_bad_exponent(bad):
    with pytest.raises(ValueError, match="exponent"):
        kappa(**bad)


def test_bad_velocity_and_peak():
    with pytest.raises(ValueError, match="v0"):
        peak_from_velocity(-1.0, 1.5)
    with pytest.raises(ValueError, match="peak"):
        velocity_from_peak(np.nan, 1.5)
