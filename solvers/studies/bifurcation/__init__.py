"""Stationary shocks in a parameter, predicted (Eq. 41) and found by DNS sweeps (paper Sec. 4.3-4.4).

Prediction: the positive roots of Eq. 41 as a parameter runs over a range, each with the
multiplier dA_i/dA_{i-1} of the map at it (stable when |multiplier| < 1), and the fold
(saddle-node) where two roots meet, for the exact and the Pade profile.

DNS: for each parameter value and each impulse v0, Eq. 1 on a chain of ``last`` contacts. The
primary pulse either

* settles: it is alive at the last contact and its peak changed by less than ``settle_tol``
  (relative) over the last ``settle_window`` contacts; its stationary amplitude is that peak;
* decays: it is lost before the last contact (the DNS's criteria: its peak falls below 1e-3 of
  the entry peak, stops advancing, or is overtaken by the self-excited wake);
* or is undecided: alive at the end but still drifting (the chain is too short to tell).

Threshold (for one impulse): the smallest parameter value at which the primary pulse settles
instead of decaying, on a chain long enough to tell. It is bracketed by the grid (largest value
that decays, smallest that settles) and refined by bisection, each probe a DNS; a probe that is
undecided is repeated on a chain twice as long (up to ``max_last``). Survival is taken to be
monotone in the parameter (true for the Van der Pol chain: the stable branch grows and the
unstable one shrinks with mu).

The predicted threshold of an impulse is the smallest parameter value at which the entry peak
(the DNS peak at contact first_perturbed - 1, which seeds the map, Eq. 32) lies above the lowest
root of Eq. 41: the fold when the entry peak is above the fold's amplitude, later otherwise.

The prediction is :mod:`~pulsemap.solvers.studies.bifurcation.predict`, the DNS probes and the
bisection :mod:`~pulsemap.solvers.studies.bifurcation.dns`, the outputs
:mod:`~pulsemap.solvers.studies.bifurcation.report`; :func:`bifurcation` runs them in order.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

from pulsemap.solvers.data.scene import PROFILES
from pulsemap.solvers.studies.bifurcation.dns import (
    BifurcationError,
    Outcome,
    ProbeRunner,
    base_chain,
    bisect,
    bracket,
    check_param,
    classify,
    entry_peak,
    probe,
    resolve_undecided,
)
from pulsemap.solvers.studies.bifurcation.predict import predict, predicted_threshold, stable_peak
from pulsemap.solvers.studies.bifurcation.relaxed import predict_relaxed, relaxed_threshold
from pulsemap.solvers.studies.bifurcation.report import plot, to_text
from pulsemap.solvers.studies.sweep import SweepError

__all__ = ["BifurcationError", "Outcome", "bifurcation", "bracket", "classify", "entry_peak", "predict",
           "predicted_threshold", "stable_peak", "to_text", "plot", "SweepError"]


def _check_arguments(scene, name: str, lo: float, hi: float, points: int, predict_points: int, refine: int,
                     rtol: float, last: int, max_last: int, impulses: Sequence[float] | None,
                     dns: bool) -> list[float] | None:
    """Every argument checked before the prediction, which takes a while; the impulses as floats."""
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise BifurcationError(f"--range {lo} {hi}: give two finite numbers A < B")
    if points < 2 or predict_points < 3:
        raise BifurcationError("give at least 2 DNS points and 3 prediction points in the range")
    if refine < 0:
        raise BifurcationError(f"refine = {refine}: give a number of bisection steps >= 0")
    check_param(scene, name)
    if not (math.isfinite(rtol) and 0 < rtol < 1):
        raise BifurcationError(f"--rtol {rtol}: give a tolerance 0 < rtol < 1 (default 1e-8)")
    if max_last < last:
        raise BifurcationError(f"max_last = {max_last} is below last = {last}")
    if impulses is not None:
        impulses = [float(v) for v in impulses]
    if dns:
        if last <= scene.first_perturbed + 1:
            raise BifurcationError(f"last contact {last} must lie beyond first_perturbed = {scene.first_perturbed}")
        for v in impulses or ():
            if not (math.isfinite(v) and v > 0):
                raise BifurcationError(f"impulse {v}: impulses are velocities v0 > 0")
    return impulses


def _thresholds(scene, name: str, report: dict, rows: list[dict], state: dict, impulses: Sequence[float],
                profiles: Sequence[str]) -> list[dict]:
    """Per impulse: the threshold (middle of the final bracket) and its uncertainty, a note when it was not
    bracketed, and the threshold Eq. 41 predicts for the impulse's entry peak, per profile."""
    thresholds = []
    for v0 in impulses:
        st = state[v0]
        a, b = st["bracket"]
        mine = [r for r in rows if r["v0"] == v0]
        entry = next((r["entry_peak"] for r in mine if r.get("entry_peak") is not None), None)
        t = {"v0": v0, "entry_peak": entry, "bracket": [a, b], "bisections": st["steps"],
             "longest_chain": st["last"], "note": st["note"], "probes": st["probes"],
             "threshold": None if (a is None or b is None) else 0.5 * (a + b),
             "uncertainty": None if (a is None or b is None) else 0.5 * (b - a), "predicted": {}, "minus_fold": {}}
        if b is not None and a is None:
            t["note"] = t["note"] or f"settles already at {name} = {b:g}: the threshold is below the range"
        if a is not None and b is None:
            t["note"] = t["note"] or f"decays up to {name} = {a:g}: the threshold is above the range (or the chain too short)"
        if a is None and b is None:
            t["note"] = t["note"] or "no grid value settled or decayed: lengthen the chain (--contacts)"
        for prof in profiles:
            pred = report["prediction"][prof]
            value = None if entry is None else predicted_threshold(scene, name, pred, entry)
            if value is not None and value == pred["branches"][0]["value"]:
                # the entry peak clears the lowest root at the range start: the threshold is at or below it
                t.setdefault("predicted_at_or_below", {})[prof] = value
                value = None
            t["predicted"][prof] = value
            if pred["folds"] and t["threshold"] is not None:
                t["minus_fold"][prof] = t["threshold"] - pred["folds"][0]["value"]
        thresholds.append(t)
    return thresholds


def _compare_stable(rows: list[dict], report: dict, profiles: Sequence[str]) -> None:
    """Each DNS stationary amplitude next to the predicted stable root at its parameter value."""
    for r in rows:
        for prof in profiles:
            sp = stable_peak(report["prediction"][prof], r["value"])
            r[f"predicted_stable_peak_{prof}"] = sp
            if r.get("amplitude") is not None and sp is not None:
                r[f"rel_diff_{prof}"] = (r["amplitude"] - sp) / sp


def bifurcation(
    scene,
    name: str,
    lo: float,
    hi: float,
    *,
    points: int = 13,
    impulses: Sequence[float] | None = None,
    last: int = 400,
    max_last: int | None = None,
    refine: int = 4,
    rtol: float = 1e-8,
    predict_points: int = 61,
    profiles: Sequence[str] = PROFILES,
    variant: str = "1d",
    settle_window: int = 50,
    settle_tol: float = 1e-3,
    out: str | None = None,
    executor=None,
    max_workers: int | None = None,
    progress: bool = False,
    retry_failed: bool = False,
    dns: bool = True,
    relaxed: bool = False,
    relaxed_points: int = 7,
) -> dict:
    """Predicted stationary branches and fold; DNS outcomes, stationary amplitudes and thresholds.

    ``retry_failed`` reruns the points ``out`` holds with an error (pulsemap.solvers.studies.sweep.run_sweep).
    ``relaxed``: also the fixed points and fold of the relaxed map (bifurcation_relaxed.py) on
    ``relaxed_points`` values, and per impulse the threshold it predicts for the entry peak."""
    max_last = max_last or 4 * last
    impulses = _check_arguments(scene, name, lo, hi, points, predict_points, refine, rtol, last, max_last,
                                impulses, dns)
    report: dict[str, Any] = {"scene": scene.as_dict(), "param": name, "range": [lo, hi], "prediction": {}}
    for prof in profiles:
        report["prediction"][prof] = predict(scene, name, lo, hi, predict_points, prof, variant)
    if relaxed:
        report["relaxed"] = predict_relaxed(scene, name, lo, hi, relaxed_points, _peak_range(scene, report, profiles))
    if not dns:
        return report
    folds = report["prediction"][profiles[0]]["folds"]
    if impulses is None:
        impulses = default_impulses(scene, folds)
    chain = base_chain(scene, last, rtol)
    runner = ProbeRunner(chain, name, scene.first_perturbed, settle_window, settle_tol, out=out, executor=executor,
                         max_workers=max_workers, progress=progress, retry_failed=retry_failed)
    values = [float(v) for v in np.linspace(lo, hi, points)]
    rows = runner.run([probe(chain, name, val, v0, last) for v0 in impulses for val in values], "bifurcation")
    rows = resolve_undecided(runner, rows, max_last)  # undecided: again on a chain twice as long
    state = bisect(runner, rows, impulses, last, max_last, refine)
    thresholds = _thresholds(scene, name, report, rows, state, impulses, profiles)
    _compare_stable(rows, report, profiles)
    if relaxed:
        _relaxed_thresholds(scene, name, lo, hi, report, thresholds, rows, last)
    report["dns"] = {
        "impulses": impulses, "values": values, "last_contact": last, "max_last": max_last, "rtol": rtol,
        "window": chain["dns"]["window"], "settle_window": settle_window, "settle_tol": settle_tol,
        "definition": "threshold: smallest parameter value at which the primary pulse of this impulse settles "
                      "(alive at the last contact, peak steady to settle_tol over settle_window contacts) "
                      "instead of decaying; bracketed by the grid, refined by bisection",
        "points": rows, "thresholds": thresholds,
    }
    report["sweeps"] = runner.sweeps
    return report


def _peak_range(scene, report: dict, profiles) -> tuple[float, float]:
    """Peaks the relaxed map's fixed points are sought in: a decade either side of Eq. 41's fold peak
    (else of the scene's incoming peak through kappa_n)."""
    folds = report["prediction"][profiles[0]]["folds"] if profiles else []
    if folds:
        centre = folds[0]["peak"]
    else:
        from pulsemap.solvers.chain.kappa import peak_from_velocity

        centre = peak_from_velocity(scene.velocity, scene.exponent)
    return centre / 10.0, centre * 10.0


def _relaxed_thresholds(scene, name: str, lo: float, hi: float, report: dict, thresholds: list[dict],
                        rows: list[dict], last: int) -> None:
    """Per impulse the relaxed model's threshold for its entry peak, and each DNS stationary amplitude
    next to the relaxed map's stable fixed point."""
    fold = report["relaxed"]["folds"][0]["value"] if report["relaxed"]["folds"] else None
    for t in thresholds:
        if t["entry_peak"] is None:
            continue
        rt = relaxed_threshold(scene, name, lo, hi, t["entry_peak"])
        t["predicted"]["relaxed"] = rt["threshold"]
        if fold is not None and t["threshold"] is not None:
            t["minus_fold"]["relaxed"] = t["threshold"] - fold
    for r in rows:
        sp = stable_peak(report["relaxed"], r["value"])
        r["predicted_stable_peak_relaxed"] = sp
        if r.get("amplitude") is not None and sp is not None:
            r["rel_diff_relaxed"] = (r["amplitude"] - sp) / sp


def default_impulses(scene, folds: list[dict]) -> list[float]:
    """Two impulses: entry peaks 0.75x and 4x the fold's (the paper's 0.3 and 2.3 for Van der Pol),
    through the impulse-to-soliton constant kappa_n; the scene's v0 when there is no fold."""
    if not folds:
        return [float(scene.velocity)]
    from pulsemap.solvers.chain.kappa import velocity_from_peak

    return [float(f"{velocity_from_peak(k * folds[0]['peak'], scene.exponent):.3g}") for k in (0.75, 4.0)]
