"""Stationary shocks predicted by Eq. 41: roots over a parameter range, their stability, the fold,
and the predicted survival threshold of an entry peak (paper Sec. 4.3)."""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

__all__ = ["predict", "predicted_threshold", "stable_peak"]


def _map(scene, profile: str, variant: str):
    """(the generated map module of the scene's R, the scene's scalar parameter values)."""
    from pulsemap.solvers.models.codeload import map_module

    pert = scene.perturbation
    mod = map_module(pert.text, pert.used_parameters, scene.exponent, profile, variant, pert.site_dependent)
    return mod, {n: float(pert.params[n]) for n in pert.used_parameters}


def predict(scene, name: str, lo: float, hi: float, points: int = 61, profile: str = "exact",
            variant: str = "1d") -> dict:
    """Roots of Eq. 41 over name in [lo, hi] with their stability, and the fold(s) in the range."""
    from pulsemap.solvers.models.stationary_shock import continue_roots, stability

    pert = scene.perturbation
    mod, base = _map(scene, profile, variant)
    cont = continue_roots(mod, base, name, lo, hi, points)
    S0 = float(mod.S0)
    branches = []
    for value, roots in zip(cont.values, cont.branches):
        prm = {**base, name: float(value)}
        rows = []
        for a in roots:
            _, lam, stable = stability(mod, a, float(pert.eps), prm)
            rows.append({"A": float(a), "peak": float(a) * S0, "multiplier": lam, "stable": stable})
        branches.append({"value": float(value), "roots": rows})
    folds = [{"value": float(p), "A": float(a), "peak": float(a) * S0} for p, a in cont.folds]
    outside = None if folds else fold_outside(mod, base, name, lo, hi, S0)
    return {"profile": profile, "variant": variant, "S0": S0, "branches": branches, "folds": folds,
            "fold_outside": outside, "generated": mod.__name__}


def fold_outside(mod, base: dict, name: str, lo: float, hi: float, S0: float, points: int = 41) -> dict | None:
    """Where Eq. 41 has its fold when [lo, hi] holds none: the nearest one found on ranges widened
    by (hi - lo) x 1, 2, 4, ..., 64 on each side; None when none is found there either."""
    from pulsemap.solvers.models.stationary_shock import continue_roots

    width = hi - lo
    for k in range(7):
        a, b = lo - width * 2 ** k, hi + width * 2 ** k
        cont = continue_roots(mod, base, name, a, b, points)
        found = [(p, x) for p, x in cont.folds if not lo <= p <= hi]
        if found:
            p, x = min(found, key=lambda f: min(abs(f[0] - lo), abs(f[0] - hi)))
            return {"value": float(p), "A": float(x), "peak": float(x) * S0, "searched": [a, b]}
    return {"value": None, "searched": [lo - 64 * width, hi + 64 * width]}


def predicted_threshold(scene, name: str, prediction: dict, peak: float) -> float | None:
    """Smallest value of ``name`` at which ``peak`` lies above the lowest root of Eq. 41.

    None when that never happens in the range; the range's start when it holds there already.
    """
    from pulsemap.solvers.models.stationary_shock import roots

    branches = prediction["branches"]

    def survives(b):
        return bool(b["roots"]) and min(r["peak"] for r in b["roots"]) <= peak

    ok = [survives(b) for b in branches]
    if True not in ok:
        return None
    j = ok.index(True)
    if j == 0:
        return branches[0]["value"]
    left = branches[j - 1]
    if not left["roots"]:  # roots are born between the two values: at the fold, if the peak clears it
        for f in prediction["folds"]:
            if left["value"] <= f["value"] <= branches[j]["value"] and f["peak"] <= peak:
                return f["value"]
    mod, base = _map(scene, prediction["profile"], prediction["variant"])
    S0 = float(mod.S0)

    def g(value: float) -> float:
        rs = roots(mod, {**base, name: value})
        return (min(rs) * S0 - peak) if rs else math.inf

    a, b = left["value"], branches[j]["value"]
    ga, gb = g(a), g(b)
    if math.isfinite(ga) and ga > 0 >= gb:
        return float(brentq(g, a, b, xtol=1e-12))
    return float(b)


def stable_peak(prediction: dict, value: float) -> float | None:
    """The predicted stable stationary peak at ``value`` (largest stable root), interpolated
    linearly in the parameter between the grid values that bracket it."""
    vals = [b["value"] for b in prediction["branches"]]
    peaks = []
    for b in prediction["branches"]:
        st = [r["peak"] for r in b["roots"] if r["stable"]]
        peaks.append(max(st) if st else math.nan)
    k = int(np.searchsorted(vals, value))
    if k < len(vals) and math.isclose(vals[k], value, rel_tol=1e-12, abs_tol=1e-15):
        return None if math.isnan(peaks[k]) else peaks[k]
    if k == 0 or k >= len(vals) or math.isnan(peaks[k - 1]) or math.isnan(peaks[k]):
        return None
    w = (value - vals[k - 1]) / (vals[k] - vals[k - 1])
    return (1 - w) * peaks[k - 1] + w * peaks[k]
