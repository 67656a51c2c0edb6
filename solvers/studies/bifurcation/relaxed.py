"""Stationary shocks from the relaxed map: its fixed points, their stability, the fold,
and the survival threshold it predicts for an entry peak, beside Eq. 41 and the DNS threshold.

A fixed point of the relaxed map P_{k+1} = F(P_k) = P_k r(P_k) is a zero of log r (a stationary
shock); it is stable when |F'(P*)| = |1 + d log r / d log P| < 1. The fold is where two fixed
points meet: where max_P log r(P) crosses zero as the parameter varies (located by bisection in
the parameter). The predicted threshold of an entry peak is the smallest parameter value at which
the relaxed model (onset, then the map) iterated from that peak is still alive after ``contacts``
contacts (bisection between the grid values that bracket it; the map is cheap, so ``contacts`` is
long enough, 20000, that a pulse passing slowly by the ghost of the fold just below it is seen
to die). Each parameter value has its own
tables (segment runs, cached), so a prediction costs a few seconds per value the first time.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

__all__ = ["fixed_points", "predict_relaxed", "relaxed_threshold"]

SCAN = 200  # log-spaced peaks per decade-range scan for sign changes of log r
BISECT = 8  # bisection steps for a fold or a threshold in the parameter


def _model(scene, name: str, value: float):
    from pulsemap.solvers.models.relaxed import model_for_scene

    pert = scene.perturbation
    values = {n: float(pert.params[n]) for n in pert.used_parameters}
    values[name] = float(value)
    return model_for_scene(scene, values)


def _log_ratio(model, contact: int):
    def g(log_p: float) -> float:
        r = model.bulk_ratio(math.exp(log_p), contact)
        return math.nan if r is None else math.log(r)
    return g


def fixed_points(model, lo_peak: float, hi_peak: float, contact: int) -> list[dict]:
    """Zeros of log r in [lo_peak, hi_peak] with F'(P*) and stability; the scan's max of log r."""
    g = _log_ratio(model, contact)
    xs = np.linspace(math.log(lo_peak), math.log(hi_peak), SCAN)
    for x in xs:  # the first scan extends the tables over the range; the second reads the final fit
        g(x)
    ys = np.array([g(x) for x in xs])
    out = []
    for a, b, ya, yb in zip(xs[:-1], xs[1:], ys[:-1], ys[1:]):
        if np.isfinite(ya) and np.isfinite(yb) and ya * yb < 0 and g(a) * g(b) < 0:
            x = brentq(g, a, b, xtol=1e-12)
            h = 1e-4
            slope = (g(x + h) - g(x - h)) / (2 * h)
            mult = 1.0 + slope
            out.append({"peak": float(math.exp(x)), "multiplier": float(mult), "stable": bool(abs(mult) < 1.0)})
    return out


def _max_log_ratio(model, lo_peak: float, hi_peak: float, contact: int) -> float:
    g = _log_ratio(model, contact)
    ys = [g(x) for x in np.linspace(math.log(lo_peak), math.log(hi_peak), SCAN)]
    finite = [y for y in ys if math.isfinite(y)]
    return max(finite) if finite else -math.inf


def predict_relaxed(scene, name: str, lo: float, hi: float, points: int, peak_range: tuple[float, float]) -> dict:
    """Fixed points of the relaxed map over ``name`` in [lo, hi] (``points`` values), with stability,
    and the fold(s) located by bisection; peaks scanned over ``peak_range``."""
    contact = scene.first_perturbed + 10  # a bulk contact (uniform R: any will do)
    p_lo, p_hi = peak_range
    branches = []
    for value in np.linspace(lo, hi, points):
        roots = fixed_points(_model(scene, name, value), p_lo, p_hi, contact)
        branches.append({"value": float(value), "roots": roots})
    folds = []
    for left, right in zip(branches[:-1], branches[1:]):
        if (len(left["roots"]) == 0) != (len(right["roots"]) == 0):
            a, b = left["value"], right["value"]
            born = len(left["roots"]) == 0  # roots appear going right
            for _ in range(BISECT):
                m = 0.5 * (a + b)
                has = _max_log_ratio(_model(scene, name, m), p_lo, p_hi, contact) > 0
                if has == born:
                    b = m
                else:
                    a = m
            value = 0.5 * (a + b)
            roots = fixed_points(_model(scene, name, b if born else a), p_lo, p_hi, contact)
            peak = float(np.exp(np.mean(np.log([r["peak"] for r in roots])))) if roots else None
            folds.append({"value": value, "uncertainty": 0.5 * (b - a), "peak": peak})
    return {"model": "relaxed", "peak_range": [p_lo, p_hi], "branches": branches, "folds": folds}


def _survives(scene, name: str, value: float, entry_peak: float, contacts: int) -> bool:
    from pulsemap.solvers.models.relaxed import iterate_relaxed

    seed = scene.first_perturbed - 1
    run = iterate_relaxed(_model(scene, name, value), entry_peak, seed, seed + contacts)
    return run.status == "ok"


def relaxed_threshold(scene, name: str, lo: float, hi: float, entry_peak: float, contacts: int = 20000,
                      points: int = 7) -> dict:
    """Smallest ``name`` in [lo, hi] at which the relaxed model from ``entry_peak`` survives ``contacts``
    contacts (survival taken monotone in the parameter, as in bifurcation.py), with its bracket."""
    values = list(np.linspace(lo, hi, points))
    alive = [_survives(scene, name, v, entry_peak, contacts) for v in values]
    if True not in alive:
        return {"threshold": None, "bracket": [values[-1], None], "note": "dies over the whole range"}
    j = alive.index(True)
    if j == 0:
        return {"threshold": values[0], "bracket": [None, values[0]], "note": "survives over the whole range"}
    a, b = values[j - 1], values[j]
    for _ in range(BISECT):
        m = 0.5 * (a + b)
        if _survives(scene, name, m, entry_peak, contacts):
            b = m
        else:
            a = m
    return {"threshold": float(0.5 * (a + b)), "bracket": [float(a), float(b)], "note": ""}
