"""A bifurcation report as text and as a Fig. 12-like plot."""

from __future__ import annotations

import numpy as np

from pulsemap.solvers.studies.bifurcation.dns import BifurcationError

__all__ = ["fixed_column", "plot", "to_text"]


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
            lo, hi = report["range"]
            out = pred.get("fold_outside") or {}
            where = (f"; Eq. 41 puts it at {name}* = {out['value']:.6f} (peak {out['peak']:.6f}), outside the range"
                     if out.get("value") is not None else
                     (f"; none in [{out['searched'][0]:g}, {out['searched'][1]:g}] either" if out.get("searched") else ""))
            lines.append(f"  predicted fold ({prof} profile): no fold in [{lo:g}, {hi:g}]{where}")
    rel = report.get("relaxed")
    if rel:
        if rel["folds"]:
            f = rel["folds"][0]
            peak = "" if f["peak"] is None else f", peak {f['peak']:.4f}"
            lines.append(f"  fold of the relaxed map (its fixed points, segment runs): {name}* = {f['value']:.4f} "
                         f"+- {f['uncertainty']:.4f}{peak}")
        else:
            lines.append("  fold of the relaxed map: none in the range")
        for b in rel["branches"]:
            roots = ", ".join(f"{x['peak']:.4f} ({'stable' if x['stable'] else 'unstable'})" for x in b["roots"])
            lines.append(f"    {name} = {b['value']:.4g}: stationary peaks {roots or 'none'}")
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
                f"  {r['value']:8.4g} {r['v0']:6.3g} {fixed_column(r.get('entry_peak'), 8, 4)} {r['outcome']:>9s} "
                f"{fixed_column(amp, 9, 5)} {fixed_column(sp, 12, 5)} {'' if diff is None else f'{100 * diff:6.2f}%':>7s}")
        for t in dns["thresholds"]:
            a, b = t["bracket"]
            if t["threshold"] is not None:
                pred = ", ".join([f"{p} {v:.4f}" for p, v in t["predicted"].items() if v is not None]
                                 + [f"{p} <= {v:g} (the range start: no predicted threshold inside [{report['range'][0]:g}, "
                                    f"{report['range'][1]:g}])" for p, v in (t.get("predicted_at_or_below") or {}).items()]) \
                    or "none in the range"
                fold = ", ".join(f"{p} {v:+.4f}" for p, v in t["minus_fold"].items())
                lines.append(f"  threshold v0 = {t['v0']:g}: {name} = {t['threshold']:.4f} +- {t['uncertainty']:.4f} "
                             f"(settles at {b:.5g}, decays at {a:.5g}; {t['bisections']} bisections); "
                             f"predicted for this impulse: {pred}; minus fold: {fold}")
            else:
                lines.append(f"  threshold v0 = {t['v0']:g}: not bracketed ({t['note']})")
            if t["note"] and t["threshold"] is not None:
                lines.append(f"    note: {t['note']}")
    return "\n".join(lines)


def fixed_column(x, width: int, prec: int) -> str:
    """A number in a fixed-width column, '-' for None."""
    return f"{'-':>{width}s}" if x is None else f"{x:{width}.{prec}f}"


def plot(report: dict, path: str) -> None:
    """A Fig. 12-like plot: stationary peaks against the parameter, stable solid, unstable
    dashed, the fold, the DNS's settled amplitudes and the thresholds found. Needs matplotlib."""
    from pulsemap.solvers.data.plotting import figures, save

    plt = figures(BifurcationError)
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
    save(fig, path)
    plt.close(fig)
