"""The relaxed map's bulk fit (models/relaxed_table.py): scipy's GCV smoothing spline, cached on disk."""

from __future__ import annotations

import numpy as np
from scipy.interpolate import make_smoothing_spline

from pulsemap.symbolic import cache
from pulsemap.solvers.models import relaxed_table as rt


def _data(seed: int = 0):
    rng = np.random.default_rng(seed)
    x = np.sort(rng.uniform(-3.0, 1.0, 40))
    return x, np.sin(x) + 0.01 * rng.standard_normal(x.size), rng.integers(1, 5, x.size).astype(float)


def test_cached_spline_is_scipys_bit_for_bit_and_read_back(monkeypatch):
    x, y, w = _data()
    direct = make_smoothing_spline(x, y, w=w)
    first = rt.cached_smoothing_spline(x, y, w)  # computed and stored
    calls = []
    monkeypatch.setattr("scipy.interpolate.make_smoothing_spline", lambda *a, **k: calls.append(1))
    second = rt.cached_smoothing_spline(x, y, w)  # read back: no fit
    assert calls == []
    t = np.linspace(-3.5, 1.5, 101)
    for spline in (first, second):
        assert np.array_equal(spline.t, direct.t) and np.array_equal(spline.c, direct.c) and spline.k == direct.k
        assert np.array_equal(spline(t), direct(t))


def test_other_data_is_another_entry_and_damage_is_recomputed():
    x, y, w = _data(1)
    a = rt.cached_smoothing_spline(x, y, w)
    b = rt.cached_smoothing_spline(x, y + 0.5, w)
    assert np.allclose(b(x) - a(x), 0.5, atol=1e-6)  # a constant shift, not the first entry read back
    # a damaged entry (non-finite coefficients) is computed again, not used
    cache.store(rt.NAMESPACE, rt.bulk_fit_key(x, y, w), {"t": [0.0], "c": [float("nan")], "k": 3})
    again = rt.cached_smoothing_spline(x, y, w)
    assert np.array_equal(again(x), a(x))
