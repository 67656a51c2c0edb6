"""Ensembles of random chains (paper Eq. 42, Fig. 13): M realisations, the map and DNS of each.

A scene whose parameters include a random per-bead draw (``k = {uniform = [0, 1], seed = 1}``)
is run M times, realisation j with the draw's seed replaced by a derived seed
``SeedSequence([seed, j, q]).generate_state(1)[0]`` (q: the parameter's place among the random
parameters, sorted by name). Realisation j's seed does not depend on M, so a larger ensemble
reuses the points of a smaller one. Each realisation is one sweep point (solvers/sweep.py):
the DNS of Eq. 1 and the map of Eq. 23 (site-dependent form, erratum 8, docs/errata.rst) seeded from the DNS
peak at contact first_perturbed - 1, exactly as ``pulsemap run`` does for one scene.

Statistics per contact, over the realisations: mean, standard deviation (ddof 1), min and max
of the DNS peak, of the map's peak and of the map's relative error against the DNS, each over the
realisations whose DNS primary pulse is alive at that contact.

Per realisation, the relaxed model (solvers/models/relaxed.py, its tables and kernel shared by
every realisation) is run in the parent from the same seed peak, and its RMS error over the
realisation's live range (the rule of ``pulsemap run``, live_range.py) stands next to the map's.

A scene with a contact law's term or masses runs through :mod:`~pulsemap.solvers.studies.terms_ensemble`.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.studies.errors import model_error
from pulsemap.solvers.studies.sweep import run_sweep

MAX_REALISATIONS = 100_000


class EnsembleError(PulsemapError):
    """An ensemble that cannot be run as asked."""


def derived_seed(seed: int, realisation: int, index: int = 0) -> int:
    """The seed of random parameter number ``index`` in realisation ``realisation``."""
    return int(np.random.SeedSequence([int(seed), int(realisation), int(index)]).generate_state(1)[0])


def check_size(scene, realisations: int, seed: int, drawn: Sequence) -> None:
    """EnsembleError unless 1 <= realisations <= MAX_REALISATIONS, seed >= 0 and the scene draws something."""
    if isinstance(realisations, bool) or not isinstance(realisations, int) or not 1 <= realisations <= MAX_REALISATIONS:
        raise EnsembleError(f"--realisations {realisations!r}: give an integer from 1 to {MAX_REALISATIONS}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise EnsembleError(f"--seed {seed!r}: give an integer >= 0")
    if not drawn:
        raise EnsembleError(
            f"scene '{scene.name}' has no random parameter: an ensemble needs a per-bead draw such as "
            "k = {uniform = [0, 1], seed = 1} (e.g. the built-in fig13-seed1) or random masses "
            "[masses] m = {uniform = [0.9, 1.1], seed = 1}")


def ensemble_points(scene, realisations: int, seed: int, *, profile: str | None = None,
                    variant: str | None = None) -> list[dict]:
    """The plain sweep points of the ensemble (generates the force and map modules here)."""
    from pulsemap.solvers.studies.points import plain_chain, random_params

    names = random_params(scene)
    check_size(scene, realisations, seed, names)
    base = plain_chain(scene, with_map=True, profile=profile, variant=variant)  # the sweep tasks' plain chains
    points = []
    for j in range(realisations):
        params = dict(base["params"])
        for q, name in enumerate(names):
            params[name] = {"uniform": list(base["params"][name]["uniform"]), "seed": derived_seed(seed, j, q)}
        points.append({**base, "params": params, "ensemble": {"seed": int(seed), "realisation": j}})
    return points


def stats(values: Sequence[float]) -> dict:
    """n, mean, std (ddof 1), min and max of the values that are not None (None where there are none)."""
    arr = np.asarray([v for v in values if v is not None], dtype=float)
    if arr.size == 0:
        return {"n": 0, "mean": None, "std": None, "min": None, "max": None}
    return {"n": int(arr.size), "mean": float(arr.mean()), "std": float(arr.std(ddof=1)) if arr.size > 1 else None,
            "min": float(arr.min()), "max": float(arr.max())}


def statistics(results: Sequence[dict], first_perturbed: int) -> dict:
    """Per-contact statistics over realisations (contacts from first_perturbed), and per-realisation errors."""
    ok = [r for r in results if r is not None]
    if not ok:
        return {"contacts": [], "dns": [], "map": [], "rel_error": [], "realisations": []}
    contacts = [c for c in ok[0]["contacts"] if c >= first_perturbed]
    per = {"dns": [], "map": [], "rel_error": []}
    for c in contacts:
        k = ok[0]["contacts"].index(c)
        per["dns"].append(stats([r["peaks"][k] for r in ok]))
        per["map"].append(stats([r["map_peaks"][k] for r in ok if r["peaks"][k] is not None]))
        per["rel_error"].append(stats([r["rel_error"][k] for r in ok]))
    rows = []
    for r in ok:  # each realisation's map error as run reports it (studies/errors.py)
        err = model_error(r["contacts"], r["peaks"], r["map_peaks"], first_perturbed - 1, r.get("seed_peak"))
        rows.append({"live_contacts": sum(1 for c, p in zip(r["contacts"], r["peaks"]) if c >= first_perturbed and p is not None),
                     **err})
    return {"contacts": contacts, **per, "realisations": rows,
            "live_contacts": stats([r["live_contacts"] for r in rows]),
            "max_pct": stats([r["max_pct"] for r in rows]),
            "rms_pct": stats([r["rms_pct"] for r in rows])}


def ensemble(scene, realisations: int, seed: int = 0, *, profile: str | None = None, variant: str | None = None,
             out: str | None = None, executor=None, max_workers: int | None = None, progress: bool = False,
             retry_failed: bool = False) -> dict:
    """Run the ensemble through the sweep engine; the report with per-contact statistics (a scene with a
    contact-law term or masses: terms_ensemble)."""
    from pulsemap.solvers.studies.points import dns_map_task
    from pulsemap.solvers.studies.run.chain_terms import has_chain_terms
    from pulsemap.solvers.studies.run.kinds import require
    from pulsemap.solvers.studies.terms_ensemble import terms_ensemble

    require(scene, "ensemble")
    if has_chain_terms(scene):
        if variant is not None:
            raise EnsembleError(f"variant {variant!r} is the map's: an ensemble of a scene with a contact-law term or "
                                "masses runs the DNS, energy-law and relaxed, no map; leave the variant out")
        return terms_ensemble(scene, realisations, seed, profile=profile, out=out, executor=executor,
                              max_workers=max_workers, progress=progress, retry_failed=retry_failed)

    points = ensemble_points(scene, realisations, seed, profile=profile, variant=variant)
    res = run_sweep(dns_map_task, points, out, executor=executor, max_workers=max_workers, progress=progress,
                    retry_failed=retry_failed, label="ensemble")
    results = res.results()
    report: dict[str, Any] = {
        "scene": scene.as_dict(),
        "seed": seed,
        "realisations": realisations,
        "derived_seeds": [{n: v["seed"] for n, v in rec["params"]["params"].items() if isinstance(v, dict)}
                          for rec in res.records],
        "choices": {"profile": profile or scene.profile, "variant": variant or scene.variant,
                    "rtol": points[0]["dns"]["rtol"]},
        "failed": [{"realisation": rec["params"]["ensemble"]["realisation"], "error": rec.get("error")}
                   for rec in res.records if rec["status"] != "ok"],
        "statistics": statistics(results, scene.first_perturbed),
        "relaxed": relaxed_errors(scene, points, results),
        "sweep": res.summary(),
    }
    return report


def relaxed_errors(scene, points: Sequence[dict], results: Sequence[dict | None]) -> dict:
    """Per realisation the error of the relaxed model and of the map against the DNS, as ``pulsemap
    run`` reports it (studies/errors.py: percent over the live range)."""
    from pulsemap.solvers.models.relaxed import RelaxedError, iterate_relaxed, model_for_scene
    from pulsemap.solvers.models.relaxed_table import SegmentRunError
    from pulsemap.solvers.studies.points import bead_params
    from pulsemap.solvers.studies.extent import on_contacts

    seed_contact = scene.first_perturbed - 1
    rows = []
    for j, (point, res) in enumerate(zip(points, results)):
        row: dict[str, Any] = {"realisation": j}
        rows.append(row)
        if res is None:
            row["error"] = "the realisation failed"
            continue
        contacts, dns, seed_peak = res["contacts"], res["peaks"], res["seed_peak"]
        row["map"] = model_error(contacts, dns, res["map_peaks"], seed_contact, seed_peak)
        row["live_range"] = row["map"]["live_range"]
        try:
            run = iterate_relaxed(model_for_scene(scene, bead_params(point)), float(seed_peak), seed_contact,
                                  int(contacts[-1]))
        except (RelaxedError, SegmentRunError) as exc:
            row["error"] = f"relaxed: {exc}"
            continue
        row["relaxed"] = model_error(contacts, dns, on_contacts(contacts, run.contacts, run.peaks), seed_contact,
                                     seed_peak)
    done = [r for r in rows if "relaxed" in r]
    return {"realisations": rows,
            **{f"{m}_rms_pct": stats([r[m]["rms_pct"] for r in done]) for m in ("relaxed", "map")}}


def to_text(report: dict) -> str:
    from pulsemap.solvers.studies.bifurcation.report import fixed_column

    sc = report["scene"]
    st = report["statistics"]
    if "models" in st:
        from pulsemap.solvers.studies.terms_ensemble import terms_text

        return terms_text(report)
    lines = [f"ensemble of {report['realisations']} realisations of {sc['name']} (R = {sc['perturbation']['R']}, "
             f"eps = {sc['perturbation']['eps']}), seed {report['seed']}; map {report['choices']['variant']}/"
             f"{report['choices']['profile']} seeded from each DNS"]
    if report["failed"]:
        lines.append(f"  {len(report['failed'])} realisations failed: " + "; ".join(
            f"#{f['realisation']}: {f['error']}" for f in report["failed"][:3]))
    if st["contacts"]:
        lc = st["live_contacts"]
        lines.append(f"  live contacts per realisation: mean {lc['mean']:.3g}, min {lc['min']:.0f}, max {lc['max']:.0f}")
        for key, label in (("rms_pct", "RMS"), ("max_pct", "max")):
            s = st[key]
            if s["n"]:
                lines.append(f"  map {label} error of a realisation (percent over its live range): mean {s['mean']:.1f} %"
                             + (f", std {s['std']:.1f} %" if s["std"] is not None else ""))
        lines += _relaxed_lines(report.get("relaxed"))
        lines.append(f"  {'contact':>7s} {'alive':>5s} {'DNS mean':>9s} {'DNS std':>8s} {'map mean':>9s} {'map std':>8s} "
                     f"{'err mean':>8s} {'err std':>8s}")
        for c, d, m, e in zip(st["contacts"], st["dns"], st["map"], st["rel_error"]):
            if d["n"] == 0:
                continue
            lines.append(f"  {c:7d} {d['n']:5d} {fixed_column(d['mean'], 9, 5)} {fixed_column(d['std'], 8, 5)} "
                         f"{fixed_column(m['mean'], 9, 5)} {fixed_column(m['std'], 8, 5)} {pct(e['mean'])} {pct(e['std'])}")
    return "\n".join(lines)


def _relaxed_lines(rel: dict | None) -> list[str]:
    """Per realisation the relaxed model's and the map's RMS error over the live range, and their means."""
    if not rel or not rel["realisations"]:
        return []
    out = ["  RMS error (percent) over each realisation's live range (a contact without a value counts 100 %):",
           f"  {'realis.':>7s} {'live':>9s} {'relaxed':>8s} {'map':>8s}"]
    for r in rel["realisations"]:
        live = "-" if not r.get("live_range") else "{}..{}".format(*r["live_range"])
        rel_rms = r["relaxed"]["rms_pct"] if "relaxed" in r else None
        map_rms = r["map"]["rms_pct"] if "map" in r else None
        out.append(f"  {r['realisation']:7d} {live:>9s} {pct(rel_rms, 1)} {pct(map_rms, 1)}"
                   + (f"  ({r['error']})" if "error" in r else ""))
    means = [rel[f"{m}_rms_pct"]["mean"] for m in ("relaxed", "map")]
    out.append(f"  {'mean':>7s} {'':>9s} {pct(means[0], 1)} {pct(means[1], 1)}")
    return out


def pct(x, scale: float = 100) -> str:
    """A fraction (scale 100) or a percent (scale 1) in an 8-wide column, '-' for None."""
    return f"{'-':>8s}" if x is None else f"{scale * x:7.1f}%"


def plot(report: dict, path: str) -> None:
    """Mean and spread (one standard deviation) of the DNS and map (or each model's) peaks per contact (Fig. 13)."""
    from pulsemap.solvers.data.plotting import figures, save

    plt = figures(EnsembleError)
    st = report["statistics"]
    series = [("dns", st["dns"])] + ([("map", st["map"])] if "map" in st else
                                     [(m, row["peaks"]) for m, row in st["models"].items() if not row["refused"]])
    colors = ("k", "tab:red", "tab:blue", "tab:green")
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for (key, stats), color in zip(series, colors):
        label = "DNS" if key == "dns" else key
        xs = [c for c, s in zip(st["contacts"], stats) if s["n"]]
        mean = np.array([s["mean"] for s in stats if s["n"]])
        std = np.array([s["std"] or 0.0 for s in stats if s["n"]])
        if xs:
            ax.plot(xs, mean, "-o" if key == "dns" else "--", color=color, ms=3, label=f"{label} mean")
            ax.fill_between(xs, mean - std, mean + std, color=color, alpha=0.15, label=f"{label} mean +- 1 std")
    ax.set_xlabel("contact i")
    ax.set_ylabel("primary pulse peak")
    ax.set_title(f"{report['scene']['name']}: {report['realisations']} realisations")
    ax.legend()
    fig.tight_layout()
    save(fig, path)
    plt.close(fig)
