"""bifurcation: a fold outside the scanned range is said so (and where Eq. 41 puts it); undecided grid
points are run again on longer chains, as docs/commands.rst says."""

from __future__ import annotations

import pytest

from pulsemap.solvers.data.scene import load_scene
from pulsemap.solvers.studies.bifurcation import predict, to_text
from pulsemap.solvers.studies.bifurcation.dns import bracket, resolve_undecided


@pytest.fixture(scope="module")
def scene():
    return load_scene("vdp-mu3-v2.3")


def test_a_fold_outside_the_range_is_located_and_named(scene):
    inside = predict(scene, "mu", 1.4, 2.0, 31)
    outside = predict(scene, "mu", 1.5, 2.0, 31)
    assert len(inside["folds"]) == 1 and outside["folds"] == []
    assert outside["fold_outside"]["value"] == pytest.approx(inside["folds"][0]["value"], rel=1e-9)
    report = {"param": "mu", "range": [1.5, 2.0], "scene": scene.as_dict(), "prediction": {"exact": outside}}
    text = to_text(report)
    assert "no fold in [1.5, 2]; Eq. 41 puts it at mu* = " in text and "outside the range" in text
    assert "1.5000" not in text


def test_no_fold_anywhere_says_where_it_looked(scene):
    pred = predict(scene, "mu", 1.5, 2.0, 11)
    pred = {**pred, "fold_outside": {"value": None, "searched": [-30.5, 34.0]}}
    report = {"param": "mu", "range": [1.5, 2.0], "scene": scene.as_dict(), "prediction": {"exact": pred}}
    assert "no fold in [1.5, 2]; none in [-30.5, 34] either" in to_text(report)


def test_a_threshold_at_the_range_start_is_not_reported_as_a_prediction(scene):
    pred = predict(scene, "mu", 1.5, 2.0, 11)
    dns = {"values": [1.5, 2.0], "impulses": [2.3], "last_contact": 400, "rtol": 1e-8, "settle_tol": 1e-3,
           "settle_window": 50, "points": [],
           "thresholds": [{"v0": 2.3, "bracket": [1.6, 1.7], "threshold": 1.65, "uncertainty": 0.05, "bisections": 0,
                           "note": None, "predicted": {"exact": None}, "predicted_at_or_below": {"exact": 1.5},
                           "minus_fold": {}}]}
    report = {"param": "mu", "range": [1.5, 2.0], "scene": scene.as_dict(), "prediction": {"exact": pred}, "dns": dns}
    text = to_text(report)
    assert "predicted for this impulse: exact <= 1.5 (the range start: no predicted threshold inside [1.5, 2])" in text


class StubRunner:
    """Undecided below 800 contacts, then settles above mu = 1.6 and decays below (a slow transient)."""

    chain = {"params": {"mu": 3.0}, "contacts": [15, 400]}
    name = "mu"

    def __init__(self):
        self.batches = []

    def run(self, batch, label):
        self.batches.append((label, [p["contacts"][1] for p in batch]))
        out = []
        for p in batch:
            last, mu = p["contacts"][1], p["params"]["mu"]
            outcome = "undecided" if last < 800 else ("settles" if mu > 1.6 else "decays")
            out.append({"value": mu, "v0": p["velocity"], "last": last, "outcome": outcome})
        return out


def test_undecided_grid_points_are_rerun_on_longer_chains():
    rows = [{"value": v, "v0": 2.3, "last": 400, "outcome": "undecided" if 1.55 < v < 1.75 else
             ("settles" if v > 1.6 else "decays")} for v in (1.5, 1.6, 1.7, 1.8)]
    assert bracket(rows) == (1.5, 1.8)
    runner = StubRunner()
    got = resolve_undecided(runner, rows, max_last=1600)
    assert runner.batches == [("longer chain", [800, 800])]
    assert [r["outcome"] for r in got] == ["decays", "decays", "settles", "settles"]
    assert got[1]["last"] == 800 and got[1]["rerun_from"] == 400 and "rerun_from" not in got[0]
    assert bracket(got) == (1.6, 1.7)  # the threshold the grid could not see


def test_rerun_stops_at_the_longest_chain():
    rows = [{"value": 1.6, "v0": 2.3, "last": 400, "outcome": "undecided"}]
    runner = StubRunner()
    assert resolve_undecided(runner, rows, max_last=700) == rows and runner.batches == []
