"""Work-precision of every way pulsemap computes a scene: error against a reference DNS vs run time.

For one scene (``bench_scene``):

* reference: the DNS of paper Eq. 1 on the full chain, DOP853 at the tightest tolerance of the
  ladder; its convergence is the max relative difference to the run at the next tolerance;
* the DNS (moving window, solvers/window.py) over a ladder of tolerances with explicit
  (DOP853, RK45) and implicit (Radau, BDF, LSODA) methods;
* baseline (b): the full-chain vectorised DNS (``simulate(window=None)``), same ladder;
* baseline (a): the script a user writes today (solvers/baselines.py: loop RHS, solve_ivp RK45,
  peaks off a sampled grid) over a ladder of tolerances and sampling steps;
* every reduced model run.py offers (``run.MODELS``: the map of Eq. 23 for each profile and
  variant, the long-wave law of Eq. 30, and whatever else is listed), seeded as ``pulsemap run``
  seeds it (the reference DNS peak at contact first_perturbed - 1, Eq. 32).

Error: max relative peak error over the contacts where the reference has a live primary pulse
(a run without a value at such a contact is counted separately as ``missing``). Time: one
warm-up run, then the best of K (DiffEqDevTools' convention); for a DNS the integrator's wall
time (force construction excluded), for a model its evaluation (derivation and code loading,
one-off and cached, excluded).

Ratios at equal accuracy (``cost_at``): a line (one method and mode over the tolerance ladder)
is interpolated log-log between the two consecutive ladder runs whose errors bracket the target
(1e-6); if every run is below the target the cheapest run's time is used (an upper bound on the
cost); if none reaches it the line has no cost at the target (no extrapolation).
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass
from typing import Callable, Sequence

import numpy as np

TARGET = 1e-6
DNS_METHODS = ("DOP853", "RK45", "Radau", "BDF", "LSODA")
QUICK_METHODS = ("DOP853", "RK45", "LSODA")


class BenchError(ValueError):
    """A benchmark that cannot be run as asked."""


@dataclass(frozen=True)
class Ladder:
    """What a benchmark measures: tolerances, methods, baseline settings, repeats."""

    rtols: tuple[float, ...] = (1e-4, 1e-6, 1e-8, 1e-10)
    reference_rtol: float = 1e-12
    check_rtol: float = 1e-11
    methods: tuple[str, ...] = DNS_METHODS
    full_methods: tuple[str, ...] = ("DOP853", "LSODA")
    script: tuple[tuple[float, float], ...] = ((1e-6, 0.01), (1e-8, 0.005), (1e-10, 0.0025))
    repeats: int = 3
    target: float = TARGET
    max_samples: float = 2e7  # baseline (a): numbers held at once (2N x samples); larger grids in segments
    models: bool = True
    baselines: bool = True


def quick_ladder(repeats: int = 1) -> Ladder:
    """A few-seconds version: three tolerances, three methods, one baseline (a) setting."""
    return Ladder(rtols=(1e-5, 1e-7, 1e-9), reference_rtol=1e-11, check_rtol=1e-10, methods=QUICK_METHODS,
                  full_methods=("DOP853",), script=((1e-7, 0.005), (1e-10, 0.002)), repeats=repeats)


@dataclass(frozen=True)
class Point:
    """One measured run: what it was, its error against the reference and its best time."""

    kind: str  # "dns", "baseline-b", "baseline-a", "model"
    line: str  # the work-precision line it belongs to (method and mode, or model)
    setting: str  # tolerance / sampling / profile, human-readable
    rtol: float | None
    error: float | None  # max relative peak error vs the reference over live contacts
    missing: int  # live reference contacts without a value
    time_s: float
    nfev: int | None = None
    note: str = ""


# ----------------------------------------------------------------------------- measuring


def best_of(run: Callable[[], tuple[object, float]], repeats: int) -> tuple[object, float]:
    """Warm up once, then the fastest of ``repeats`` runs: (last result, best time)."""
    result, _ = run()
    best = math.inf
    for _ in range(max(1, repeats)):
        result, seconds = run()
        best = min(best, seconds)
    return result, best


def peak_error(peaks: Sequence[float | None], ref: Sequence[float | None]) -> tuple[float | None, int]:
    """(max relative error over contacts where ``ref`` has a value, contacts missing a value)."""
    rel, missing = [], 0
    for p, r in zip(peaks, ref):
        if r is None:
            continue
        if p is None or not math.isfinite(p):
            missing += 1
            continue
        rel.append(abs(p / r - 1.0))
    return (max(rel) if rel else None), missing


def cost_at(points: Sequence[Point], target: float) -> tuple[float | None, str]:
    """Time a line needs for max error ``target`` (see the module docstring for how)."""
    pts = sorted((p for p in points if p.error is not None and p.missing == 0), key=lambda p: -(p.rtol or 0.0))
    if not pts:
        return None, "no complete run"
    below = [p for p in pts if p.error <= target]
    if not below:
        return None, f"no run reached {target:g} (best {min(p.error for p in pts):.2g})"
    for a, b in zip(pts, pts[1:]):
        if a.error > target >= b.error:
            ea, eb = math.log(max(a.error, 1e-300)), math.log(max(b.error, 1e-300))
            ta, tb = math.log(a.time_s), math.log(b.time_s)
            w = (math.log(target) - ea) / (eb - ea) if eb != ea else 1.0
            return math.exp(ta + w * (tb - ta)), f"interpolated between {a.setting} and {b.setting}"
    cheapest = min(below, key=lambda p: p.time_s)
    if pts[0].error <= target:
        return cheapest.time_s, f"every run below {target:g}: cheapest ({cheapest.setting}), an upper bound"
    return cheapest.time_s, f"cheapest run below {target:g} ({cheapest.setting})"


def tolerances(scene, rtol: float) -> dict:
    """rtol and an atol scaled to the scene's strain and velocity scales (extreme v0 too)."""
    from pulsemap.solvers.chain.dns import velocity_scale

    scale = min(scene.velocity, velocity_scale(scene.velocity, scene.exponent))
    return {"rtol": float(rtol), "atol": float(rtol * 1e-2 * scale)}


# ----------------------------------------------------------------------------- one scene


def reference_run(scene, rtol: float) -> dict:
    """``pulsemap run`` with the DNS only (full chain, DOP853) at ``rtol``: its result dict."""
    from pulsemap.solvers.studies.run import run_scene

    tuned = scene.with_overrides(dns={**tolerances(scene, rtol), "method": "DOP853"})
    return run_scene(tuned, methods=["dns"])


def dns_points(scene, contacts: list[int], ref: list, ladder: Ladder, window, methods, kind: str,
               log: Callable[[str], None]) -> list[Point]:
    """The DNS of the scene over the tolerance ladder for each method (window or full chain)."""
    from pulsemap.solvers.chain.dns import simulate
    from pulsemap.solvers.studies.points import dns_span, on_contacts
    from pulsemap.solvers.studies.run import make_force

    beads, span = dns_span(scene)
    force = make_force(scene, beads)
    mode = "window" if window else "full"
    out = []
    for method in methods:
        for rtol in ladder.rtols:
            def run(method=method, rtol=rtol):
                res = simulate(beads, scene.exponent, scene.velocity, span, force, method=method, window=window,
                               **tolerances(scene, rtol))
                return res, res.wall_time_s

            res, best = best_of(run, ladder.repeats)
            err, missing = peak_error(on_contacts(contacts, res.contacts, res.peaks, res.alive), ref)
            point = Point(kind, f"{mode} {method}", f"rtol {rtol:g}", rtol, err, missing, best, int(res.nfev),
                          "" if missing == 0 else res.stop_reason)
            log(f"  {kind:10s} {point.line:14s} {point.setting:11s} err {fmt(err)} missing {missing:3d} "
                f"time {best:8.4f} s nfev {res.nfev}")
            out.append(point)
    return out


def script_points(scene, contacts: list[int], ref: list, ladder: Ladder,
                  log: Callable[[str], None]) -> list[Point]:
    """Baseline (a) over its (rtol, sampling step) ladder; skipped where its grid would not fit.

    It integrates to 3 contact times past the last live peak of a windowed DNS (as short as a
    user who knows when the pulse gets there would make it) and samples every ``dt`` contact
    times (dt scaled by the contact time v0^(-(n-1)/(n+1)), so extreme v0 get the same grid).
    """
    from pulsemap.solvers.studies.baselines import baseline_script, script_force
    from pulsemap.solvers.chain.dns import contact_rate, simulate
    from pulsemap.solvers.studies.points import dns_span, on_contacts
    from pulsemap.solvers.studies.run import make_force

    beads, span = dns_span(scene)
    probe = simulate(beads, scene.exponent, scene.velocity, span, make_force(scene, beads),
                     window="auto", **tolerances(scene, 1e-8))
    contact_time = 1.0 / contact_rate(scene.velocity, scene.exponent)
    t_end = float(np.nanmax(probe.peak_times[probe.alive])) + 3.0 * contact_time
    force_py = script_force(scene, beads)
    out = []
    for rtol, dt in ladder.script:
        dt_s = dt * contact_time  # same samples per contact time whatever v0
        samples = t_end / dt_s
        setting = f"rtol {rtol:g} dt {dt:g}"
        # a grid too big for memory is integrated in segments, as a user would (same grid, same peaks)
        segment = None if 2 * beads * samples <= ladder.max_samples else max(16, int(ladder.max_samples / (2 * beads)))

        def run(rtol=rtol, dt_s=dt_s, segment=segment):
            res = baseline_script(beads, scene.exponent, scene.velocity, span, force_py,
                                  rtol=rtol, atol=tolerances(scene, rtol)["atol"], dt_sample=dt_s, t_end=t_end,
                                  segment_samples=segment)
            return res, res.wall_time_s

        res, best = best_of(run, min(ladder.repeats, 2))
        err, missing = peak_error(on_contacts(contacts, res.contacts, res.peaks, res.alive), ref)
        point = Point("baseline-a", "script RK45", setting, rtol, err, missing, best, int(res.nfev))
        log(f"  baseline-a {point.line:14s} {setting:11s} err {fmt(err)} missing {missing:3d} time {best:8.4f} s")
        out.append(point)
    return out


def model_points(scene, reference: dict, ref: list, ladder: Ladder, log: Callable[[str], None]) -> list[Point]:
    """Every reduced model run.py offers, each profile (and map variant), against the reference."""
    from pulsemap.solvers.studies import run as run_mod
    from pulsemap.solvers.data.scene import PROFILES, VARIANTS

    out = []
    for model in run_mod.MODELS:
        for profile in PROFILES:
            for variant in (VARIANTS if model == "map" else (None,)):
                def run(model=model, profile=profile, variant=variant):
                    r = run_mod.run_scene(scene, methods=[model], profile=profile,
                                          variant=variant or scene.variant, reuse_dns=reference)
                    return r, float(r["timings_s"].get(model, math.nan))

                try:
                    res, best = best_of(run, ladder.repeats)
                except ValueError as exc:
                    log(f"  model      {model}: refused ({exc})")
                    continue
                peaks = res["peaks"].get(model)
                label = f"{model}/{profile}" + (f"/{variant}" if variant else "")
                if peaks is None or not math.isfinite(best):
                    why = "; ".join(w for w in res.get("warnings", []) if model in w) or "no value"
                    log(f"  model      {label}: not computed ({why})")
                    continue
                err, missing = peak_error(peaks, ref)
                point = Point("model", label, profile + (f" {variant}" if variant else ""), None, err, missing,
                              best, None, f"{missing} live contacts without a value" if missing else "")
                log(f"  model      {label:24s} err {fmt(err)} missing {missing:3d} time {best:10.6f} s")
                out.append(point)
    return out


def bench_scene(scene, ladder: Ladder = Ladder(), log: Callable[[str], None] = lambda s: None) -> dict:
    """Work-precision report of one scene (JSON-able; see the module docstring)."""
    from pulsemap.solvers.studies.points import dns_span

    wall0 = time.perf_counter()
    c0, c1 = scene.contacts
    contacts = list(range(c0, c1 + 1))
    beads, _ = dns_span(scene)
    log(f"scene {scene.name}: R = {scene.perturbation.text}, eps = {scene.perturbation.eps:g}, "
        f"v0 = {scene.velocity:g}, n = {scene.exponent:g}, {beads} beads, contacts {c0}..{c1}")
    reference = reference_run(scene, ladder.reference_rtol)
    check = reference_run(scene, ladder.check_rtol)
    ref = reference["peaks"]["dns"]
    if not any(p is not None for p in ref):
        raise BenchError(f"scene {scene.name}: the reference DNS has no live primary pulse on contacts "
                         f"{c0}..{c1} ({reference['dns']['stop_reason']}): nothing to measure")
    conv, conv_missing = peak_error(check["peaks"]["dns"], ref)
    ref_note = (f"DOP853 full chain rtol {ladder.reference_rtol:g}: {reference['dns']['stop_reason']}; "
                f"max rel difference to rtol {ladder.check_rtol:g}: {fmt(conv)}"
                + (f" ({conv_missing} contacts missing)" if conv_missing else ""))
    log("  reference: " + ref_note)
    live = [c for c, p in zip(contacts, ref) if p is not None]

    points = dns_points(scene, contacts, ref, ladder, "auto", ladder.methods, "dns", log)
    if ladder.baselines:
        points += dns_points(scene, contacts, ref, ladder, None, ladder.full_methods, "baseline-b", log)
        points += script_points(scene, contacts, ref, ladder, log)
    default_dns = None
    if ladder.models:
        points += model_points(scene, reference, ref, ladder, log)
        from pulsemap.solvers.studies.run import run_scene

        _, default_dns = best_of(lambda: _timed_dns(run_scene(scene, methods=["dns"])), ladder.repeats)
        log(f"  the DNS as `pulsemap run` does it (scene settings, full chain): {default_dns:.4g} s")

    lines: dict[str, list[Point]] = {}
    for p in points:
        lines.setdefault(f"{p.kind}|{p.line}", []).append(p)
    costs = {key: cost_at(pts, ladder.target) for key, pts in lines.items() if pts[0].kind != "model"}
    ratios = summarize(points, costs, default_dns, ladder.target, scene)
    return {
        "scene": scene.name,
        "beads": beads,
        "contacts": [c0, c1],
        "live_contacts": len(live),
        "reference": {"method": "DOP853", "mode": "full", "rtol": ladder.reference_rtol,
                      "check_rtol": ladder.check_rtol, "convergence": conv, "missing": conv_missing,
                      "stop_reason": reference["dns"]["stop_reason"],
                      "time_s": reference["timings_s"].get("dns")},
        "target": ladder.target,
        "points": [asdict(p) for p in points],
        "cost_at_target": {key: {"time_s": t, "how": how} for key, (t, how) in costs.items()},
        "ratios": ratios,
        "bench_time_s": time.perf_counter() - wall0,
    }


def _timed_dns(result: dict) -> tuple[dict, float]:
    return result, float(result["timings_s"]["dns"])


def _best(costs: dict, kind: str) -> tuple[float | None, str]:
    found = [(t, key.split("|", 1)[1]) for key, (t, _) in costs.items() if key.startswith(kind + "|") and t]
    return min(found) if found else (None, "")


def summarize(points: list[Point], costs: dict, default_dns: float | None, target: float, scene) -> dict:
    """Speed ratios at equal accuracy, and the models' speed against the DNS."""
    dns_t, dns_line = _best(costs, "dns")
    b_t, b_line = _best(costs, "baseline-b")
    a_t, a_line = _best(costs, "baseline-a")
    out: dict = {
        "target": target,
        "dns": {"time_s": dns_t, "line": dns_line},
        "baseline_b": {"time_s": b_t, "line": b_line},
        "baseline_a": {"time_s": a_t, "line": a_line},
        "dns_vs_b": (b_t / dns_t) if dns_t and b_t else None,
        "dns_vs_a": (a_t / dns_t) if dns_t and a_t else None,
    }
    models = [p for p in points if p.kind == "model"]
    if models:
        fastest_dns = min((p.time_s for p in points if p.kind == "dns"), default=None)
        default_line = f"map/{scene.profile}/{scene.variant}"
        default = next((p for p in models if p.line == default_line), None)
        best_model = min(models, key=lambda p: (p.error if p.error is not None else math.inf))
        slowest = max(p.time_s for p in models)
        out["models"] = {
            "map_line": default_line,
            "map_time_s": None if default is None else default.time_s,
            "map_error": None if default is None else default.error,
            "slowest_model_time_s": slowest,
            "most_accurate": {"line": best_model.line, "error": best_model.error, "time_s": best_model.time_s},
            "run_dns_time_s": default_dns,
            "run_dns_vs_map": (default_dns / default.time_s) if default and default_dns else None,
            "dns_at_target_vs_map": (dns_t / default.time_s) if default and dns_t else None,
            "fastest_dns_vs_map": (fastest_dns / default.time_s) if default and fastest_dns else None,
            "run_dns_vs_slowest_model": (default_dns / slowest) if default_dns else None,
        }
    return out


# ----------------------------------------------------------------------------- reports


def fmt(x: float | None, spec: str = ".2e") -> str:
    return "-" if x is None else format(x, spec)


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
            lines.append(f"  {p['kind']:10s} {p['line']:26s} {p['setting']:18s} {fmt(p['error']):>11s} "
                         f"{p['missing']:7d} {p['time_s']:10.4g} {'' if p['nfev'] is None else p['nfev']:>8}")
        rat = r["ratios"]
        t = rat["target"]
        lines.append(f"  at max rel error {t:g} (log-log interpolation on each line; best line of each kind):")
        for key, label in (("dns", "pulsemap DNS"), ("baseline_b", "baseline (b) full chain"),
                           ("baseline_a", "baseline (a) user script")):
            e = rat[key]
            lines.append(f"    {label:26s} {fmt(e['time_s'], '.4g'):>10s} s  {e['line']}")
        lines.append(f"    ratio (b)/DNS = {fmt(rat['dns_vs_b'], '.3g')}   ratio (a)/DNS = {fmt(rat['dns_vs_a'], '.3g')}")
        if "models" in rat:
            m = rat["models"]
            lines.append(f"    map ({m['map_line']}): {fmt(m['map_time_s'], '.3g')} s, max rel err {fmt(m['map_error'])};"
                         f" DNS of `pulsemap run` ({fmt(m['run_dns_time_s'], '.3g')} s) / map = "
                         f"{fmt(m['run_dns_vs_map'], '.3g')}, DNS at {t:g} / map = {fmt(m['dns_at_target_vs_map'], '.3g')},"
                         f" fastest DNS run / map = {fmt(m['fastest_dns_vs_map'], '.3g')}")
            lines.append(f"    slowest model {m['slowest_model_time_s']:.3g} s (DNS of `pulsemap run` / it = "
                         f"{fmt(m['run_dns_vs_slowest_model'], '.3g')}); most accurate model "
                         f"{m['most_accurate']['line']} (max rel err {fmt(m['most_accurate']['error'])})")
        lines.append(f"  (benchmark took {r['bench_time_s']:.1f} s)")
    return "\n".join(lines)


def to_csv(reports: list[dict]) -> str:
    """One row per measured run."""
    rows = ["scene,kind,line,setting,rtol,max_rel_error,missing,time_s,nfev"]
    for r in reports:
        for p in r["points"]:
            rows.append(",".join([r["scene"], p["kind"], p["line"], p["setting"],
                                  "" if p["rtol"] is None else repr(p["rtol"]),
                                  "" if p["error"] is None else repr(p["error"]), str(p["missing"]),
                                  repr(p["time_s"]), "" if p["nfev"] is None else str(p["nfev"])]))
    return "\n".join(rows) + "\n"


def plot(reports: list[dict], path: str) -> None:
    """Log-log error against time, one panel per scene (matplotlib, optional)."""
    from pulsemap.solvers.data.plotting import pyplot

    plt = pyplot(BenchError)
    fig, axes = plt.subplots(1, len(reports), figsize=(6.5 * len(reports), 4.8), squeeze=False)
    styles = {"dns": "o-", "baseline-b": "s--", "baseline-a": "^:", "model": "x"}
    for ax, r in zip(axes[0], reports):
        lines: dict[str, list] = {}
        for p in r["points"]:
            if p["error"] is not None and p["error"] > 0 and p["missing"] == 0:
                lines.setdefault((p["kind"], p["line"]), []).append((p["time_s"], p["error"]))
        for (kind, line), pts in lines.items():
            xs, ys = zip(*pts)
            ax.loglog(xs, ys, styles.get(kind, "o"), label=f"{kind} {line}" if kind != "model" else line, ms=4)
        ax.axhline(r["target"], color="grey", lw=0.8, label=f"target {r['target']:g}")
        ax.set_xlabel("run time [s] (best of K)")
        ax.set_ylabel("max relative peak error vs reference DNS")
        ax.set_title(r["scene"])
        ax.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def run_bench(names: Sequence[str], ladder: Ladder, log: Callable[[str], None] = lambda s: None) -> list[dict]:
    """Benchmark each scene (names or TOML paths) in turn."""
    from pulsemap.solvers.data.scene import load_scene

    scenes = [load_scene(n) for n in names]  # all load errors before any work
    return [bench_scene(s, ladder, log) for s in scenes]


__all__ = ["Ladder", "Point", "BenchError", "bench_scene", "run_bench", "cost_at", "peak_error", "best_of",
           "quick_ladder", "to_text", "to_csv", "plot"]
