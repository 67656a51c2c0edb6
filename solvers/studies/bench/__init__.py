"""Work-precision of every way pulsemap computes a scene: error against a reference DNS vs run time.

For one scene (``bench_scene``):

* reference: the DNS of paper Eq. 1 on the full chain, DOP853 at the tightest tolerance of the
  ladder; its convergence is the max relative difference to the run at the next tolerance;
* the DNS on the scipy engine (moving window, solvers/window.py) over a ladder of tolerances with
  explicit (DOP853, RK45) and implicit (Radau, BDF, LSODA) methods;
* the compiled engine (numba RK45 and DOP853, moving window) and the careful user's vectorised script
  (studies/bench/reference_script.py) over their ladders, and each of the three engines once more cold
  (first call of a fresh process, empty numba cache): :mod:`~pulsemap.solvers.studies.bench.engines`;
* baseline (b): the full-chain vectorised DNS (``simulate(..., window=None)``), same ladder;
* baseline (a): the script a user writes today (solvers/baselines.py: loop RHS, solve_ivp RK45,
  peaks off a sampled grid) over a ladder of tolerances and sampling steps;
* every reduced model run.py offers (``run.MODELS``: the map of Eq. 23 for each profile and
  variant, the long-wave law of Eq. 30, and whatever else is listed), seeded as ``pulsemap run``
  seeds it (the reference DNS peak at contact first_perturbed - 1, Eq. 32).

Error of a DNS: max relative peak error over the contacts where the reference has a live primary
pulse (a run without a value at such a contact is counted separately as ``missing``). Error of a
model: ``pulsemap run``'s (studies/errors.py: RMS and max in percent over the live range, against
the reference DNS; ``Point.rms_pct`` and ``Point.max_pct``, the plot shows the max as a fraction). Time: one
warm-up run, then the best of K (DiffEqDevTools' convention); for a DNS the integrator's wall
time (force construction excluded), for a model its evaluation (derivation and code loading,
one-off and cached, excluded).

Ratios at equal accuracy (``cost_at``): a line (one method and mode over the tolerance ladder)
is interpolated log-log between the two consecutive ladder runs whose errors bracket the target
(1e-6); if every run is below the target the cheapest run's time is used (an upper bound on the
cost); if none reaches it the line has no cost at the target (no extrapolation).

The measurements are :mod:`~pulsemap.solvers.studies.bench.measure`, the lines measured
:mod:`~pulsemap.solvers.studies.bench.lines`, the reports :mod:`~pulsemap.solvers.studies.bench.report`.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import asdict
from typing import Callable, Sequence

from pulsemap.solvers.studies.bench.lines import (dns_points, model_points, reference_run, script_points,
                                                  scripts_refusal)
from pulsemap.solvers.studies.bench.measure import (
    DNS_METHODS,
    QUICK_METHODS,
    TARGET,
    BenchError,
    Ladder,
    Point,
    best_line,
    best_of,
    cost_at,
    fmt,
    peak_error,
    quick_ladder,
    tolerances,
)
from pulsemap.solvers.studies.bench.engines import cold_runs, engine_ratios, reference_points
from pulsemap.solvers.studies.bench.report import plot, to_csv, to_text
from pulsemap.solvers.studies.errors import counted


def bench_scene(scene, ladder: Ladder = Ladder(), log: Callable[[str], None] = lambda s: None) -> dict:
    """Work-precision report of one scene (JSON-able; see the module docstring)."""
    from pulsemap.solvers.studies.extent import dns_span
    from pulsemap.solvers.studies.run.kinds import require

    require(scene, "bench")
    wall0 = time.perf_counter()
    c0, c1 = scene.contacts
    contacts = list(range(c0, c1 + 1))
    beads, _ = dns_span(scene)
    log(f"scene {scene.name}: R = {scene.perturbation.text}, eps = {scene.perturbation.eps:g}, "
        + (f"P = {scene.contact.text}, eps_c = {scene.contact.eps:g}, " if scene.contact is not None else "")
        + (f"m = {scene.masses.text}, " if scene.masses is not None else "")
        + f"v0 = {scene.velocity:g}, n = {scene.exponent:g}, {beads} beads, contacts {c0}..{c1}")
    no_scripts = scripts_refusal(scene)
    if no_scripts and (ladder.engines or ladder.baselines):
        log(f"  script lines: not measured ({no_scripts})")
    reference = reference_run(scene, ladder.reference_rtol)
    check = reference_run(scene, ladder.check_rtol)
    ref = reference["peaks"]["dns"]
    if not any(p is not None for p in ref):
        raise BenchError(f"scene {scene.name}: the reference DNS has no live primary pulse on contacts "
                         f"{c0}..{c1} ({reference['dns']['stop_reason']}): nothing to measure")
    conv, conv_missing = peak_error(check["peaks"]["dns"], ref)
    ref_note = (f"DOP853 full chain rtol {ladder.reference_rtol:g}: {reference['dns']['stop_reason']}; "
                f"max rel difference to rtol {ladder.check_rtol:g}: {fmt(conv)}"
                + (f" ({counted(conv_missing, 'contact')} missing)" if conv_missing else ""))
    log("  reference: " + ref_note)
    live = [c for c, p in zip(contacts, ref) if p is not None]

    points = dns_points(scene, contacts, ref, ladder, "auto", ladder.methods, "dns", log)
    if ladder.engines:
        points += dns_points(scene, contacts, ref, ladder, "auto", ladder.compiled_methods, "compiled", log,
                             engine="compiled", rtols=ladder.compiled_rtols)
        points += [] if no_scripts else reference_points(scene, contacts, ref, ladder, log)
    if ladder.baselines:
        points += dns_points(scene, contacts, ref, ladder, None, ladder.full_methods, "baseline-b", log)
        points += [] if no_scripts else script_points(scene, contacts, ref, ladder, log)
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
    cold = {}
    if ladder.engines:
        if ladder.cold:
            cold = cold_runs(scene, ref, [asdict(p) for p in points], ladder.target, log)
        ratios["engines"] = engine_ratios(costs, cold)
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
        "cold": cold,
        **({"scripts_not_measured": no_scripts} if no_scripts else {}),
        "load_average": os.getloadavg()[0],
        "bench_time_s": time.perf_counter() - wall0,
    }


def _timed_dns(result: dict) -> tuple[dict, float]:
    return result, float(result["timings_s"]["dns"])


def summarize(points: list[Point], costs: dict, default_dns: float | None, target: float, scene) -> dict:
    """Speed ratios at equal accuracy, and the models' speed against the DNS."""
    dns_t, dns_line = best_line(costs, "dns")
    b_t, b_line = best_line(costs, "baseline-b")
    a_t, a_line = best_line(costs, "baseline-a")
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
        best_model = min(models, key=lambda p: (p.rms_pct if p.rms_pct is not None else math.inf))
        slowest = max(p.time_s for p in models)
        out["models"] = {
            "map_line": default_line,
            "map_time_s": None if default is None else default.time_s,
            "map_rms_pct": None if default is None else default.rms_pct,
            "slowest_model_time_s": slowest,
            "most_accurate": {"line": best_model.line, "rms_pct": best_model.rms_pct, "time_s": best_model.time_s},
            "run_dns_time_s": default_dns,
            "run_dns_vs_map": (default_dns / default.time_s) if default and default_dns else None,
            "dns_at_target_vs_map": (dns_t / default.time_s) if default and dns_t else None,
            "fastest_dns_vs_map": (fastest_dns / default.time_s) if default and fastest_dns else None,
            "run_dns_vs_slowest_model": (default_dns / slowest) if default_dns else None,
        }
    return out


def run_bench(names: Sequence[str], ladder: Ladder, log: Callable[[str], None] = lambda s: None,
              sets: Sequence[str] = ()) -> list[dict]:
    """Benchmark each scene (names or TOML paths, with the --set assignments ``sets``) in turn."""
    from pulsemap.solvers.data.scene.overrides import with_sets
    from pulsemap.solvers.data.scene import load_scene
    from pulsemap.solvers.studies.progress import Progress

    scenes = [with_sets(load_scene(n), sets) for n in names]  # all load errors before any work
    report = Progress("bench", len(scenes), sink=log)
    out = []
    for scene in scenes:
        report.start(scene.name)
        t0 = time.perf_counter()
        out.append(bench_scene(scene, ladder, log))
        report.finish(scene.name, "done", time.perf_counter() - t0)
    return out


__all__ = ["DNS_METHODS", "QUICK_METHODS", "TARGET", "Ladder", "Point", "BenchError", "bench_scene", "run_bench",
           "cost_at", "peak_error", "best_of", "fmt", "quick_ladder", "tolerances", "to_text", "to_csv", "plot",
           "dns_points", "model_points", "reference_run", "script_points"]
