"""The fast GCV search (models/gcv_spline.py) against scipy's make_smoothing_spline, and the cached
leave-one-run-out accuracy (models/relaxed_table.py) against its refit."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import make_smoothing_spline

from pulsemap.solvers.models import relaxed_table as rt
from pulsemap.solvers.models.gcv_spline import gcv_smoothing_spline


@pytest.mark.parametrize("seed", range(12))
def test_equals_scipys_spline_bit_for_bit(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(5, 160))
    x = np.unique(rng.uniform(-4.0, 1.0, n))
    y = np.cos(3 * x) + rng.normal(0.0, 10 ** rng.uniform(-7, 0), x.size)  # from interpolation to heavy smoothing
    w = rng.integers(1, 7, x.size).astype(float)
    ours, ref = gcv_smoothing_spline(x, y, w), make_smoothing_spline(x, y, w=w)
    assert ours.k == ref.k and np.array_equal(ours.t, ref.t) and np.array_equal(ours.c, ref.c)


def test_bad_input_is_a_value_error():
    x = np.linspace(0.0, 1.0, 8)
    with pytest.raises(ValueError, match="ascending"):
        gcv_smoothing_spline(x[::-1], x, np.ones(8))
    with pytest.raises(ValueError, match=">= 5"):
        gcv_smoothing_spline(x[:4], x[:4], np.ones(4))


def _table(seed: int) -> rt.SegmentTable:
    """A table of synthetic runs: peaks decaying by a smooth map of the peak plus noise."""
    rng = np.random.default_rng(seed)
    table = rt.SegmentTable(rt.SegmentSpec("-u", (), 1.0, 1.5))
    for j in range(-6, 6):
        p = [rt.lattice_amplitude(j)]
        for _ in range(rt.CONTACTS):
            p.append(p[-1] * np.exp(-0.05 * p[-1] ** -0.4 + 1e-4 * rng.standard_normal()))
        table.runs[j] = [float(v) for v in p]
    return table


def test_leave_one_out_is_the_refit_and_read_back_from_one_entry(monkeypatch):
    table = _table(3)
    ref = 0.0  # the definition: scipy's fit of the other runs' binned points, worst error on the left-out run
    for j in table.runs:
        others = {i: p for i, p in table.runs.items() if i != j}
        xo, yo = table.bulk_points(others)
        edges = np.floor((xo - xo[0]) / rt.BIN).astype(int)
        g = np.unique(edges, return_inverse=True)[1]
        cnt = np.bincount(g)
        fit = make_smoothing_spline(np.bincount(g, weights=xo) / cnt, np.bincount(g, weights=yo) / cnt,
                                    w=cnt.astype(float))
        xj, yj = table.bulk_points({j: table.runs[j]})
        inside = (xj >= xo[0]) & (xj <= xo[-1])
        ref = max(ref, float(np.max(np.abs(fit(xj[inside]) - yj[inside]))))
    assert ref > 0.0
    assert rt.leave_one_out(table) == ref
    monkeypatch.setattr(rt, "_leave_one_out", lambda t: pytest.fail("refit instead of the cached value"))
    assert rt.leave_one_out(table) == ref
    table.runs[0] = table.runs[0][:-1]  # other runs: another entry
    with pytest.raises(pytest.fail.Exception):
        rt.leave_one_out(table)
