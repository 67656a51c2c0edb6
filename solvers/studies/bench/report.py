"""A benchmark's reports: work-precision tables and ratios, CSV rows, and the log-log plot."""

from __future__ import annotations

from pulsemap.solvers.studies.bench.measure import BenchError, fmt
from pulsemap.solvers.studies.errors import DEFINITION

__all__ = ["engine_lines", "plot", "to_csv", "to_text"]


def to_text(reports: list[dict]) -> str:
    """Work-precision tables and the ratios, one block per scene."""
    lines = []
    for r in reports:
        ref = r["reference"]
        lines.append(f"scene {r['scene']}: {r['beads']} beads, contacts {r['contacts'][0]}..{r['contacts'][1]}, "
                     f"{r['live_contacts']} live; reference DOP853 full chain rtol {ref['rtol']:g} "
                     f"({ref['time_s']:.3g} s), converged to {fmt(ref['convergence'])} vs rtol {ref['check_rtol']:g}")
        lines.append(f"  {'kind':10s} {'line':26s} {'setting':18s} {'max rel err':>11s} {'missing':>7s} "
                     f"{'time [s]':>10s} {'nfev':>8s}")
        for p in r["points"]:
            if p["kind"] == "model":
                continue
            lines.append(f"  {p['kind']:10s} {p['line']:26s} {p['setting']:18s} {fmt(p['error']):>11s} "
                         f"{p['missing']:7d} {p['time_s']:10.4g} {'' if p['nfev'] is None else p['nfev']:>8}")
        if r.get("scripts_not_measured"):
            lines.append(f"  the user's scripts (baseline (a), script): not measured ({r['scripts_not_measured']})")
        models = [p for p in r["points"] if p["kind"] == "model"]
        if models:
            span = next((p["live_range"] for p in models if p.get("live_range")), None)
            lines.append("  models against the reference DNS (" + DEFINITION
                         + (f"; live range {span[0]}..{span[1]}" if span else "") + "):")
            for p in models:
                lines.append(f"  {'model':10s} {p['line']:26s} RMS {fmt(p['rms_pct'], '.3g'):>6s} %  max "
                             f"{fmt(p['max_pct'], '.3g'):>6s} %  time {p['time_s']:.4g} s"
                             + (f"  ({p['note']})" if p.get("note") else ""))
        rat = r["ratios"]
        t = rat["target"]
        lines.append(f"  at max rel error {t:g} (log-log interpolation on each line; best line of each kind):")
        for key, label in (("dns", "DNS, scipy engine"), ("baseline_b", "baseline (b) full chain"),
                           ("baseline_a", "baseline (a) user script")):
            e = rat[key]
            lines.append(f"    {label:26s} {fmt(e['time_s'], '.4g'):>10s} s  {e['line']}")
        lines.append(f"    ratio (b)/DNS = {fmt(rat['dns_vs_b'], '.3g')}   ratio (a)/DNS = {fmt(rat['dns_vs_a'], '.3g')}")
        if "models" in rat:
            m = rat["models"]
            lines.append(f"    map ({m['map_line']}): {fmt(m['map_time_s'], '.3g')} s, RMS {fmt(m['map_rms_pct'], '.3g')} %;"
                         f" DNS of `pulsemap run` ({fmt(m['run_dns_time_s'], '.3g')} s) / map = "
                         f"{fmt(m['run_dns_vs_map'], '.3g')}, DNS at {t:g} / map = {fmt(m['dns_at_target_vs_map'], '.3g')},"
                         f" fastest DNS run / map = {fmt(m['fastest_dns_vs_map'], '.3g')}")
            lines.append(f"    slowest model {m['slowest_model_time_s']:.3g} s (DNS of `pulsemap run` / it = "
                         f"{fmt(m['run_dns_vs_slowest_model'], '.3g')}); most accurate model "
                         f"{m['most_accurate']['line']} (RMS {fmt(m['most_accurate']['rms_pct'], '.3g')} %)")
        if "engines" in rat:
            lines += engine_lines(rat["engines"], r.get("cold", {}), t)
        lines.append(f"  (benchmark took {r['bench_time_s']:.1f} s)")
    return "\n".join(lines)


def engine_lines(e: dict, cold: dict, target: float) -> list[str]:
    """The compiled engine against the careful user's script and the scipy engine, warm and cold."""
    out = [f"  engines at max rel error {target:g}, warm (best of K, log-log interpolation):"]
    for key, label in (("compiled", "compiled engine"), ("scipy", "scipy engine"), ("script", "user's script")):
        out.append(f"    {label:26s} {fmt(e[key]['time_s'], '.4g'):>10s} s  {e[key]['line']}")
    out.append(f"    RATIO script / compiled = {fmt(e['compiled_vs_script'], '.4g')}   "
               f"RATIO scipy engine / compiled = {fmt(e['compiled_vs_scipy'], '.4g')}")
    if cold:
        out.append("  cold (first call in a fresh process, empty numba cache: JIT included; the cheapest run "
                   f"reaching {target:g}):")
        for kind, label in (("compiled", "compiled engine"), ("dns", "scipy engine"), ("script", "user's script")):
            c = cold.get(kind)
            if c:
                out.append(f"    {label:26s} {c['first_call_s']:10.4g} s ({c['first_call_cpu_s']:.3g} s CPU)  "
                           f"{c['line']} {c['setting']}, err {fmt(c['error'])}; whole process {c['process_wall_s']:.3g} s"
                           f" ({c['process_cpu_s']:.3g} s CPU)")
        k = e["cold"]
        out.append(f"    RATIO cold script / compiled = {fmt(k.get('compiled_vs_script'), '.4g')} "
                   f"(CPU {fmt(k.get('compiled_vs_script_cpu'), '.4g')}, whole process CPU "
                   f"{fmt(k.get('compiled_vs_script_process_cpu'), '.4g')})   RATIO cold scipy engine / compiled = "
                   f"{fmt(k.get('compiled_vs_scipy'), '.4g')} (CPU {fmt(k.get('compiled_vs_scipy_cpu'), '.4g')})")
    return out


def to_csv(reports: list[dict]) -> str:
    """One row per measured run: a DNS run's max relative error against the reference (a fraction, as rtol), a
    model's RMS and max error in percent (studies/errors.py)."""
    rows = ["scene,kind,line,setting,rtol,max_rel_error,missing,time_s,nfev,rms_pct,max_pct"]
    for r in reports:
        for p in r["points"]:
            rows.append(",".join([r["scene"], p["kind"], p["line"], p["setting"],
                                  "" if p["rtol"] is None else repr(p["rtol"]),
                                  "" if p["error"] is None else repr(p["error"]), str(p["missing"]),
                                  repr(p["time_s"]), "" if p["nfev"] is None else str(p["nfev"]),
                                  "" if p.get("rms_pct") is None else repr(p["rms_pct"]),
                                  "" if p.get("max_pct") is None else repr(p["max_pct"])]))
    return "\n".join(rows) + "\n"


def plot(reports: list[dict], path: str) -> None:
    """Log-log error against time, one panel per scene (matplotlib, optional)."""
    from pulsemap.solvers.data.plotting import figures, save

    plt = figures(BenchError)
    fig, axes = plt.subplots(1, len(reports), figsize=(6.5 * len(reports), 4.8), squeeze=False)
    styles = {"dns": "o-", "baseline-b": "s--", "baseline-a": "^:", "model": "x", "compiled": "D-", "script": "v-."}
    names = {"dns": "scipy engine", "compiled": "compiled engine", "script": "user's script"}
    for ax, r in zip(axes[0], reports):
        lines: dict[str, list] = {}
        for p in r["points"]:
            err = p["max_pct"] / 100 if p["kind"] == "model" and p.get("max_pct") is not None else p["error"]
            if err is not None and err > 0 and p["missing"] == 0:
                lines.setdefault((p["kind"], p["line"]), []).append((p["time_s"], err))
        for (kind, line), pts in lines.items():
            xs, ys = zip(*pts)
            ax.loglog(xs, ys, styles.get(kind, "o"), label=f"{names.get(kind, kind)} {line}" if kind != "model" else line,
                      ms=4)
        for kind, c in r.get("cold", {}).items():  # cold: first call of a fresh process (JIT included)
            if c["error"] is not None and c["error"] > 0:
                ax.loglog([c["first_call_s"]], [c["error"]], styles.get(kind, "o")[0], mfc="none", ms=9, mew=1.5,
                          label=f"cold {names.get(kind, kind)} ({c['setting']})")
        ax.axhline(r["target"], color="grey", lw=0.8, label=f"target {r['target']:g}")
        ax.set_xlabel("run time [s] (warm: best of K; hollow: cold first call)")
        ax.set_ylabel("max relative peak error vs reference DNS")
        ax.set_title(r["scene"])
        ax.legend(fontsize=6)
    fig.tight_layout()
    save(fig, path)
    plt.close(fig)
