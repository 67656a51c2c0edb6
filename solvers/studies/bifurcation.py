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
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
from scipy.optimize import brentq

from pulsemap.solvers.studies.points import dns_task
from pulsemap.solvers.data.scene import PROFILES
from pulsemap.solvers.studies.sweep import SweepError, run_sweep


class BifurcationError(ValueError):
    """A bifurcation sweep that cannot be run as asked."""


# ----------------------------------------------------------------------------- classification


@dataclass(frozen=True)
class Outcome:
    """What the primary pulse did in one DNS run."""

    kind: str  # "settles" | "decays" | "undecided"
    amplitude: float | None  # stationary peak when it settles
    final_peak: float | None  # last live peak
    alive_to: int | None  # last contact with a live primary pulse
    drift: float | None  # relative change of the peak over the last settle_window contacts


def classify(result: dict, settle_window: int = 50, settle_tol: float = 1e-3) -> Outcome:
    """Settles, decays or undecided, from a DNS task's peaks (see the module docstring)."""
    contacts, peaks = result["contacts"], result["peaks"]
    last = contacts[-1]
    alive_to = result.get("alive_to")
    live = [p for p in peaks if p is not None]
    final = live[-1] if live else None
    if alive_to is None or alive_to < last:
        kind = "decays" if "died" in result.get("stop_reason", "") else "undecided"
        return Outcome(kind, None, final, alive_to, None)
    j = len(peaks) - 1 - settle_window
    ref = peaks[j] if j >= 0 else None
    if ref is None:
        return Outcome("undecided", None, final, alive_to, None)
    drift = (final - ref) / final
    if abs(drift) <= settle_tol:
        return Outcome("settles", final, final, alive_to, drift)
    return Outcome("undecided", None, final, alive_to, drift)


def entry_peak(result: dict, first_perturbed: int) -> float | None:
    """The DNS peak at contact first_perturbed - 1 (what seeds the map, Eq. 32)."""
    c = first_perturbed - 1
    return result["peaks"][result["contacts"].index(c)] if c in result["contacts"] else None


# ----------------------------------------------------------------------------- prediction


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
    return {"profile": profile, "variant": variant, "S0": S0, "branches": branches, "folds": folds,
            "generated": mod.__name__}


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


# ----------------------------------------------------------------------------- DNS sweeps


def check_param(scene, name: str) -> None:
    """``name`` must be a scalar parameter of the scene's R."""
    pert = scene.perturbation
    if name not in pert.used_parameters:
        used = ", ".join(pert.used_parameters) or "none"
        raise BifurcationError(f"'{name}' is not a parameter of R = {pert.text} (parameters: {used}): choose one with --param")
    if name in pert.site_dependent:
        raise BifurcationError(f"parameter '{name}' varies along the chain: the bifurcation needs a scalar parameter")
    if pert.site_dependent:
        raise BifurcationError(f"parameter '{pert.site_dependent[0]}' varies along the chain: Eq. 41 needs a uniform "
                               "chain, give it a single value")


def base_chain(scene, last: int, rtol: float, window: "int | str | None" = "auto") -> dict:
    """The plain chain of the DNS probes (contacts first_perturbed - 1 .. last; bifurcation() checks last)."""
    from pulsemap.solvers.studies.points import plain_chain

    sc = scene.with_overrides(contacts=(scene.first_perturbed, int(last)), beads=None)
    return plain_chain(sc, window=window, rtol=rtol)


def probe(chain: dict, name: str, value: float, v0: float, last: int) -> dict:
    """The plain point of one DNS probe: parameter ``name`` = value, impulse v0, ``last`` contacts."""
    from pulsemap.solvers.chain.dns import chain_length_for

    p = {**chain, "params": {**chain["params"], name: float(value)}, "velocity": float(v0),
         "contacts": [chain["contacts"][0], int(last)], "beads": chain_length_for(int(last))}
    return p


def _summary(rec: dict, name: str, first_perturbed: int, settle_window: int, settle_tol: float) -> dict:
    prm = rec["params"]
    row = {"value": prm["params"][name], "v0": prm["velocity"], "last": prm["contacts"][1], "key": rec["key"]}
    if rec["status"] != "ok":
        row.update({"outcome": "failed", "error": rec.get("error")})
        return row
    res = rec["result"]
    out = classify(res, settle_window, settle_tol)
    row.update({"outcome": out.kind, "amplitude": out.amplitude, "final_peak": out.final_peak,
                "alive_to": out.alive_to, "drift": out.drift, "entry_peak": entry_peak(res, first_perturbed),
                "stop_reason": res["stop_reason"], "elapsed_s": rec.get("elapsed_s")})
    return row


def bracket(rows: Sequence[dict]) -> tuple[float | None, float | None]:
    """(largest value that decays below the smallest that settles, smallest that settles)."""
    settles = sorted(r["value"] for r in rows if r["outcome"] == "settles")
    if not settles:
        return (max((r["value"] for r in rows if r["outcome"] == "decays"), default=None), None)
    hi = settles[0]
    below = [r["value"] for r in rows if r["outcome"] == "decays" and r["value"] < hi]
    return (max(below) if below else None, hi)


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
) -> dict:
    """Predicted stationary branches and fold; DNS outcomes, stationary amplitudes and thresholds.

    ``retry_failed`` reruns the points ``out`` holds with an error (pulsemap.solvers.studies.sweep.run_sweep)."""
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise BifurcationError(f"--range {lo} {hi}: give two finite numbers A < B")
    if points < 2 or predict_points < 3:
        raise BifurcationError("give at least 2 DNS points and 3 prediction points in the range")
    if refine < 0:
        raise BifurcationError(f"refine = {refine}: give a number of bisection steps >= 0")
    check_param(scene, name)
    if not (math.isfinite(rtol) and 0 < rtol < 1):
        raise BifurcationError(f"--rtol {rtol}: give a tolerance 0 < rtol < 1 (default 1e-8)")
    max_last = max_last or 4 * last
    if max_last < last:
        raise BifurcationError(f"max_last = {max_last} is below last = {last}")
    if impulses is not None:
        impulses = [float(v) for v in impulses]
    if dns:  # before the prediction, which takes a while
        if last <= scene.first_perturbed + 1:
            raise BifurcationError(f"last contact {last} must lie beyond first_perturbed = {scene.first_perturbed}")
        for v in impulses or ():
            if not (math.isfinite(v) and v > 0):
                raise BifurcationError(f"impulse {v}: impulses are velocities v0 > 0")
    report: dict[str, Any] = {"scene": scene.as_dict(), "param": name, "range": [lo, hi], "prediction": {}}
    for prof in profiles:
        report["prediction"][prof] = predict(scene, name, lo, hi, predict_points, prof, variant)
    if not dns:
        return report
    folds = report["prediction"][profiles[0]]["folds"]
    if impulses is None:
        impulses = default_impulses(scene, folds)
    chain = base_chain(scene, last, rtol)
    values = [float(v) for v in np.linspace(lo, hi, points)]
    grid = [probe(chain, name, val, v0, last) for v0 in impulses for val in values]
    sweeps = []
    res = run_sweep(dns_task, grid, out, executor=executor, max_workers=max_workers, progress=progress,
                    retry_failed=retry_failed, label="bifurcation")
    sweeps.append(res.summary())
    fp = scene.first_perturbed
    rows = [_summary(r, name, fp, settle_window, settle_tol) for r in res.records]

    # bisection rounds, all impulses at once
    state = {}
    for v0 in impulses:
        mine = [r for r in rows if r["v0"] == v0]
        state[v0] = {"bracket": list(bracket(mine)), "last": last, "steps": 0, "note": None, "probes": []}
    for _ in range(refine):
        todo = {}
        for v0, st in state.items():
            a, b = st["bracket"]
            if a is None or b is None or st["note"]:
                continue
            todo[v0] = 0.5 * (a + b)
        if not todo:
            break
        pending = dict(todo)
        while pending:
            batch = [probe(chain, name, mid, v0, state[v0]["last"]) for v0, mid in pending.items()]
            res = run_sweep(dns_task, batch, out, executor=executor, max_workers=max_workers,
                            progress=progress, retry_failed=retry_failed, label="bisection")
            sweeps.append(res.summary())
            again = {}
            for v0, rec in zip(pending, res.records):
                row = _summary(rec, name, fp, settle_window, settle_tol)
                st = state[v0]
                st["probes"].append(row)
                if row["outcome"] == "settles":
                    st["bracket"][1] = pending[v0]
                    st["steps"] += 1
                elif row["outcome"] == "decays":
                    st["bracket"][0] = pending[v0]
                    st["steps"] += 1
                elif row["outcome"] == "undecided" and 2 * st["last"] <= max_last:
                    st["last"] *= 2
                    again[v0] = pending[v0]
                else:
                    st["note"] = (f"bisection stopped at {name} = {pending[v0]:.6g}: {row['outcome']} on "
                                  f"{st['last']} contacts")
            pending = again

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
            t["predicted"][prof] = None if entry is None else predicted_threshold(scene, name, pred, entry)
            if pred["folds"] and t["threshold"] is not None:
                t["minus_fold"][prof] = t["threshold"] - pred["folds"][0]["value"]
        thresholds.append(t)

    for r in rows:  # DNS stationary amplitude next to the predicted stable root
        for prof in profiles:
            sp = stable_peak(report["prediction"][prof], r["value"])
            r[f"predicted_stable_peak_{prof}"] = sp
            if r.get("amplitude") is not None and sp is not None:
                r[f"rel_diff_{prof}"] = (r["amplitude"] - sp) / sp
    report["dns"] = {
        "impulses": impulses, "values": values, "last_contact": last, "max_last": max_last, "rtol": rtol,
        "window": chain["dns"]["window"], "settle_window": settle_window, "settle_tol": settle_tol,
        "definition": "threshold: smallest parameter value at which the primary pulse of this impulse settles "
                      "(alive at the last contact, peak steady to settle_tol over settle_window contacts) "
                      "instead of decaying; bracketed by the grid, refined by bisection",
        "points": rows, "thresholds": thresholds,
    }
    report["sweeps"] = sweeps
    return report


def default_impulses(scene, folds: list[dict]) -> list[float]:
    """Two impulses: entry peaks 0.75x and 4x the fold's (the paper's 0.3 and 2.3 for Van der Pol),
    through the impulse-to-soliton constant kappa_n; the scene's v0 when there is no fold."""
    if not folds:
        return [float(scene.velocity)]
    from pulsemap.solvers.chain.kappa import velocity_from_peak

    return [float(f"{velocity_from_peak(k * folds[0]['peak'], scene.exponent):.3g}") for k in (0.75, 4.0)]


# ----------------------------------------------------------------------------- output


def to_text(report: dict) -> str:
    name = report["param"]
    sc = report["scene"]
    lines = [f"scene {sc['name']}: R = {sc['perturbation']['R']}, eps = {sc['perturbation']['eps']}, "
             f"{name} in [{report['range'][0]:g}, {report['range'][1]:g}]"]
    for prof, pred in report["prediction"].items():
        if pred["folds"]:
            f = pred["folds"][0]
            lines.append(f"  predicted fold ({prof} profile, Eq. 41, {pred['variant']} map): {name}* = {f['value']:.6f}, "
                         f"peak {f['peak']:.6f}")
        else:
            lines.append(f"  predicted fold ({prof} profile): none in the range")
    dns = report.get("dns")
    if dns:
        lines.append(f"  DNS: {len(dns['values'])} values x {len(dns['impulses'])} impulses, chain to contact "
                     f"{dns['last_contact']} (rtol {dns['rtol']:g}); settles = steady to {dns['settle_tol']:g} "
                     f"over the last {dns['settle_window']} contacts")
        lines.append(f"  {name:>8s} {'v0':>6s} {'entry':>8s} {'outcome':>9s} {'DNS peak':>9s} {'Eq.41 stable':>12s} {'diff':>7s}")
        for r in sorted(dns["points"], key=lambda r: (r["v0"], r["value"])):
            amp = r.get("amplitude")
            sp = r.get("predicted_stable_peak_exact")
            diff = r.get("rel_diff_exact")
            lines.append(
                f"  {r['value']:8.4g} {r['v0']:6.3g} {_f(r.get('entry_peak'), 8, 4)} {r['outcome']:>9s} "
                f"{_f(amp, 9, 5)} {_f(sp, 12, 5)} {'' if diff is None else f'{100 * diff:6.2f}%':>7s}")
        for t in dns["thresholds"]:
            a, b = t["bracket"]
            if t["threshold"] is not None:
                pred = ", ".join(f"{p} {v:.4f}" for p, v in t["predicted"].items() if v is not None)
                fold = ", ".join(f"{p} {v:+.4f}" for p, v in t["minus_fold"].items())
                lines.append(f"  threshold v0 = {t['v0']:g}: {name} = {t['threshold']:.4f} +- {t['uncertainty']:.4f} "
                             f"(settles at {b:.5g}, decays at {a:.5g}; {t['bisections']} bisections); "
                             f"predicted for this impulse: {pred}; minus fold: {fold}")
            else:
                lines.append(f"  threshold v0 = {t['v0']:g}: not bracketed ({t['note']})")
            if t["note"] and t["threshold"] is not None:
                lines.append(f"    note: {t['note']}")
    return "\n".join(lines)


def _f(x, width: int, prec: int) -> str:
    return f"{'-':>{width}s}" if x is None else f"{x:{width}.{prec}f}"


def plot(report: dict, path: str) -> None:
    """A Fig. 12-like plot: stationary peaks against the parameter, stable solid, unstable
    dashed, the fold, the DNS's settled amplitudes and the thresholds found. Needs matplotlib."""
    from pulsemap.solvers.data.plotting import pyplot

    plt = pyplot(BifurcationError)
    name = report["param"]
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    styles = {"exact": ("k", 1.6), "pade": ("tab:gray", 0.9)}
    for prof, pred in report["prediction"].items():
        color, lw = styles.get(prof, ("k", 1.0))
        for want, ls in ((True, "-"), (False, "--")):
            xs = [f["value"] for f in pred["folds"]]  # both branches start at the fold
            ys = [f["peak"] for f in pred["folds"]]
            for b in pred["branches"]:
                for r in b["roots"]:
                    if r["stable"] is want:
                        xs.append(b["value"])
                        ys.append(r["peak"])
            if len(xs) > len(pred["folds"]):
                order = np.argsort(xs)
                label = f"Eq. 41 {'stable' if want else 'unstable'} ({prof})"
                ax.plot(np.array(xs)[order], np.array(ys)[order], ls=ls, color=color, lw=lw, label=label)
        if pred["folds"]:
            ax.plot([f["value"] for f in pred["folds"]], [f["peak"] for f in pred["folds"]], "o", color=color,
                    ms=5, label=f"fold ({prof})")
    dns = report.get("dns")
    if dns:
        markers = "s^Dv<>"
        for k, v0 in enumerate(dns["impulses"]):
            rows = [r for r in dns["points"] if r["v0"] == v0]
            rows += [r for t in dns["thresholds"] if t["v0"] == v0 for r in t.get("probes", [])]
            xs = [r["value"] for r in rows if r["outcome"] == "settles"]
            ys = [r["amplitude"] for r in rows if r["outcome"] == "settles"]
            ax.plot(xs, ys, markers[k % 6], mfc="none", color=f"C{k}", label=f"DNS settles, v0 = {v0:g}")
            xd = [r["value"] for r in rows if r["outcome"] == "decays"]
            ax.plot(xd, [0.0] * len(xd), "x", color=f"C{k}", label=f"DNS decays, v0 = {v0:g}" if xd else None)
        for k, t in enumerate(dns["thresholds"]):
            if t["threshold"] is not None:
                ax.axvline(t["threshold"], color=f"C{k}", lw=0.8, ls=":",
                           label=f"DNS threshold, v0 = {t['v0']:g}")
    ax.set_xlabel(name)
    ax.set_ylabel("stationary peak (A S(0))")
    ax.set_title(f"{report['scene']['name']}: stationary shocks")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


__all__ = ["BifurcationError", "Outcome", "bifurcation", "bracket", "classify", "predict",
           "predicted_threshold", "stable_peak", "to_text", "plot", "SweepError"]
