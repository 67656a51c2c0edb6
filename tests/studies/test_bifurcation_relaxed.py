"""Fixed points and fold of the relaxed map (studies/bifurcation/relaxed.py) on maps with known answers."""

from __future__ import annotations

import math

import pytest

from pulsemap.solvers.studies.bifurcation import relaxed as br


class FakeModel:
    """log r(P) = mu - (log P)^2: fixed points at P = exp(+-sqrt(mu)) for mu > 0, a fold at mu = 0."""

    def __init__(self, mu: float):
        self.mu = mu

    def bulk_ratio(self, peak: float, contact: int) -> float:
        return math.exp(self.mu - math.log(peak) ** 2)


def test_fixed_points_and_their_stability():
    roots = br.fixed_points(FakeModel(0.04), 0.1, 10.0, 20)
    assert [r["peak"] for r in roots] == pytest.approx([math.exp(-0.2), math.exp(0.2)], rel=1e-9)
    # F'(P*) = 1 + d log r / d log P = 1 - 2 log P*: 1.4 (unstable) below, 0.6 (stable) above
    assert [r["multiplier"] for r in roots] == pytest.approx([1.4, 0.6], abs=1e-6)
    assert [r["stable"] for r in roots] == [False, True]
    assert br.fixed_points(FakeModel(-0.1), 0.1, 10.0, 20) == []


def test_the_fold_is_where_the_fixed_points_are_born(monkeypatch):
    monkeypatch.setattr(br, "_model", lambda scene, name, value: FakeModel(value - 0.3))

    class Scene:
        first_perturbed = 16

    pred = br.predict_relaxed(Scene(), "mu", 0.0, 1.0, 6, (0.1, 10.0))
    (fold,) = pred["folds"]
    assert abs(fold["value"] - 0.3) <= fold["uncertainty"] + 1e-12 and fold["uncertainty"] < 0.01
    assert [len(b["roots"]) for b in pred["branches"]] == [0, 0, 2, 2, 2, 2]
