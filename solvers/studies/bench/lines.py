"""The measured lines of a benchmark: the reference DNS, the DNS and baseline (b) over the tolerance
ladder, baseline (a) (the user's script) and every reduced model."""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.data.scene import with_overrides
from pulsemap.solvers.studies.bench.measure import Ladder, Point, best_of, fmt, peak_error, tolerances
from pulsemap.solvers.studies.errors import counted

__all__ = ["dns_points", "model_points", "reference_run", "script_points", "script_span",
           "scripts_refusal"]


def scripts_refusal(scene) -> str | None:
    """Why the user's scripts (baseline (a), reference_script.py) cannot run the scene, or None: they integrate an
    on-site R on unit masses."""
    from pulsemap.solvers.studies.run.chain_terms import has_chain_terms

    if not has_chain_terms(scene):
        return None
    return "the user's scripts integrate an on-site R on unit masses; this scene has a contact-law term or masses"


def reference_run(scene, rtol: float) -> dict:
    """``pulsemap run`` with the DNS only (full chain, DOP853 on the scipy engine, independent of the
    compiled one) at ``rtol``: its result dict."""
    from pulsemap.solvers.studies.run import run_scene

    tuned = with_overrides(scene, dns={**tolerances(scene, rtol), "method": "DOP853", "engine": "scipy"})
    return run_scene(tuned, methods=["dns"])


def dns_points(scene, contacts: list[int], ref: list, ladder: Ladder, window, methods, kind: str,
               log: Callable[[str], None], engine: str = "scipy", rtols=None) -> list[Point]:
    """The DNS of the scene over the tolerance ladder (``rtols``, default ladder.rtols) for each method
    (window or full chain) on ``engine`` ("scipy": the reference engine, "compiled": the numba one)."""
    from pulsemap.solvers.chain.dns import Integrator, simulate
    from pulsemap.solvers.studies.extent import dns_span, on_contacts
    from pulsemap.solvers.studies.scene_chain import scene_chain

    beads, span = dns_span(scene)
    chain = scene_chain(scene, beads)
    mode = "window" if window else "full"
    out = []
    for method in methods:
        for rtol in (ladder.rtols if rtols is None else rtols):
            def run(method=method, rtol=rtol):
                res = simulate(chain, span, window=window,
                               integrator=Integrator(method=method, engine=engine, **tolerances(scene, rtol)))
                return res, res.wall_time_s

            res, best = best_of(run, ladder.repeats)
            err, missing = peak_error(on_contacts(contacts, res.contacts, res.peaks, res.alive), ref)
            note = "" if missing == 0 else res.stop_reason
            if res.engine != engine:  # the compiled engine refused the case: say so, the point is the scipy engine's
                note = (note + "; " if note else "") + f"ran on the {res.engine} engine: {res.engine_reason}"
            point = Point(kind, f"{mode} {method}", f"rtol {rtol:g}", rtol, err, missing, best, int(res.nfev), note)
            log(f"  {kind:10s} {point.line:14s} {point.setting:11s} err {fmt(err)} missing {missing:3d} "
                f"time {best:8.4f} s nfev {res.nfev}")
            out.append(point)
    return out


def script_span(scene) -> tuple[float, float]:
    """(t_end, contact time) of a script run: 3 contact times past the last live peak of a windowed
    DNS at rtol 1e-8 (as short as a user who knows when the pulse gets there would make it)."""
    from pulsemap.solvers.chain.dns import Integrator, contact_rate, simulate
    from pulsemap.solvers.studies.scene_chain import scene_chain
    from pulsemap.solvers.studies.extent import dns_span

    beads, span = dns_span(scene)
    probe = simulate(scene_chain(scene, beads), span,
                     window="auto", integrator=Integrator(**tolerances(scene, 1e-8)))
    contact_time = 1.0 / contact_rate(scene.velocity, scene.exponent)
    return float(np.nanmax(probe.peak_times[probe.alive])) + 3.0 * contact_time, contact_time


def script_points(scene, contacts: list[int], ref: list, ladder: Ladder,
                  log: Callable[[str], None]) -> list[Point]:
    """Baseline (a) over its (rtol, sampling step) ladder; skipped where its grid would not fit.

    It integrates to 3 contact times past the last live peak of a windowed DNS (as short as a
    user who knows when the pulse gets there would make it) and samples every ``dt`` contact
    times (dt scaled by the contact time v0^(-(n-1)/(n+1)), so extreme v0 get the same grid).
    """
    from pulsemap.solvers.studies.bench.baselines import baseline_script, script_force
    from pulsemap.solvers.studies.extent import dns_span, on_contacts

    beads, span = dns_span(scene)
    t_end, contact_time = script_span(scene)
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
    from pulsemap.solvers.data.scene import PROFILES, VARIANTS
    from pulsemap.solvers.studies.methods import MODELS
    from pulsemap.solvers.studies.run import run_scene

    out = []
    for model in MODELS:
        for profile in PROFILES:
            for variant in (VARIANTS if model == "map" else (None,)):
                def run(model=model, profile=profile, variant=variant):
                    r = run_scene(scene, methods=[model], profile=profile,
                                  variant=variant or scene.variant, reuse_dns=reference)
                    return r, float(r["timings_s"].get(model, math.nan))

                try:
                    res, best = best_of(run, ladder.repeats)
                except PulsemapError as exc:
                    log(f"  model      {model}: refused ({exc})")
                    continue
                peaks = res["peaks"].get(model)
                label = f"{model}/{profile}" + (f"/{variant}" if variant else "")
                if peaks is None or not math.isfinite(best):
                    why = "; ".join(w for w in res.get("warnings", []) if model in w) or "no value"
                    log(f"  model      {label}: not computed ({why})")
                    continue
                e = res["errors"][model]  # studies/errors.py: every output's error, against the reference DNS
                point = Point("model", label, profile + (f" {variant}" if variant else ""), None, None, e["missing"],
                              best, None, f"{counted(e['missing'], 'live contact')} without a value (counted 100 %)"
                              if e["missing"] else "", rms_pct=e["rms_pct"], max_pct=e["max_pct"],
                              live_range=None if e["live_range"] is None else tuple(e["live_range"]))
                log(f"  model      {label:24s} RMS {fmt(e['rms_pct'], '.3g')} % max {fmt(e['max_pct'], '.3g')} % "
                    f"time {best:10.6f} s")
                out.append(point)
    return out
