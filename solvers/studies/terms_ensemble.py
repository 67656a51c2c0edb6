"""Ensembles of a scene with a contact law's term or masses (random masses, a random contact parameter, or either
beside a random R): each realisation, its draws' seeds derived as in studies/ensemble.py, runs as ``pulsemap run``
does (:func:`terms_task`): the DNS and TERMS_MODELS (the energy law; relaxed, the kernel in the local masses, where
it applies), each model's peaks and errors against the DNS, with per-contact statistics."""

from __future__ import annotations

from typing import Any, Mapping, Sequence

from pulsemap.solvers.studies.ensemble import check_size, derived_seed, pct, stats
from pulsemap.solvers.studies.sweep import run_sweep

__all__ = ["TERMS_MODELS", "drawn_keys", "terms_ensemble", "terms_points", "terms_statistics", "terms_task",
           "terms_text"]

#: The models an ensemble of a scene with a contact-law term or masses runs besides the DNS (a model the scene's
#: terms refuse says why in the report, studies/run/chain_terms.py).
TERMS_MODELS = ("energy-law", "relaxed")


def drawn_keys(scene) -> list[tuple[str, ...]]:
    """Where the scene's per-bead random draws sit in its dict form (scene.as_dict()): the masses' m and the
    parameters of [contact], [masses] and [perturbation], sorted by dotted name (their order q in derived_seed)."""
    data = scene.as_dict()
    found = [("masses", "m")] if _is_draw((data.get("masses") or {}).get("m")) else []
    for table in ("contact", "masses", "perturbation"):
        found += [(table, "params", name) for name, value in ((data.get(table) or {}).get("params") or {}).items()
                  if _is_draw(value)]
    return sorted(found, key=".".join)


def _is_draw(value: object) -> bool:
    return isinstance(value, dict) and "seed" in value


def terms_points(scene, realisations: int, seed: int, *, profile: str | None = None) -> list[dict]:
    """The sweep points of an ensemble of a scene with a contact-law term or masses: the scene's dict with each
    draw's seed replaced by derived_seed(seed, j, q) (q: its place in drawn_keys); realisation 0 is parsed here,
    so a bad scene fails before anything runs."""
    from pulsemap.solvers.data.scene import parse_scene

    keys = drawn_keys(scene)
    check_size(scene, realisations, seed, keys)
    points = []
    for j in range(realisations):
        data = scene.as_dict()
        for q, key in enumerate(keys):
            table = data
            for part in key[:-1]:
                table = table[part]
            table[key[-1]] = {**table[key[-1]], "seed": derived_seed(seed, j, q)}
        points.append({"scene": data, "methods": ["dns", *TERMS_MODELS], "profile": profile or scene.profile,
                       "ensemble": {"seed": int(seed), "realisation": j}})
    parse_scene(points[0]["scene"], scene.source or "ensemble")
    return points


def terms_task(point: Mapping[str, Any]) -> dict:
    """Sweep task: one realisation run as ``pulsemap run`` runs it; the peaks of the DNS and of each model, the
    models' errors against the DNS (studies/errors.py), why a model was refused, the DNS's bead-velocity peaks."""
    from pulsemap.solvers.data.scene import parse_scene
    from pulsemap.solvers.studies.run import run_scene

    scene = parse_scene(point["scene"], point["scene"].get("source") or "ensemble")
    res = run_scene(scene, methods=point["methods"], profile=point["profile"])
    dns = res.get("dns") or {}
    models = [m for m in point["methods"] if m != "dns"]
    return {"contacts": res["contacts"], "peaks": {m: res["peaks"].get(m) for m in point["methods"]},
            "seed_peak": dns.get("seed_peak"), "errors": res["errors"],
            "refused": {m: res[m]["refused"] for m in models if "refused" in (res.get(m) or {})},
            "velocity_peaks": dns.get("velocity_peaks")}


def terms_statistics(results: Sequence[dict | None], models: Sequence[str]) -> dict:
    """Per-contact statistics over the realisations of a contact-law or mass ensemble: the DNS peak, each model's
    peak and relative error against the DNS (over the realisations whose DNS is alive there), the DNS's bead-velocity
    peaks; per realisation each model's error as run reports it, and their statistics."""
    ok = [r for r in results if r is not None]
    if not ok:
        return {"contacts": [], "dns": [], "models": {}, "realisations": []}
    contacts = ok[0]["contacts"]

    def column(r: dict, m: str) -> list:
        return r["peaks"].get(m) or [None] * len(contacts)

    out: dict[str, Any] = {"contacts": contacts,
                           "dns": [stats([r["peaks"]["dns"][k] for r in ok]) for k in range(len(contacts))]}
    out["models"] = {}
    for m in models:
        peaks, errors = [], []
        for k in range(len(contacts)):
            pairs = [(column(r, m)[k], r["peaks"]["dns"][k]) for r in ok if r["peaks"]["dns"][k] is not None]
            peaks.append(stats([p for p, _ in pairs]))
            errors.append(stats([None if p is None else abs(p - d) / abs(d) for p, d in pairs]))
        done = [r["errors"][m] for r in ok if m in r["errors"]]
        refused = sorted({r["refused"][m] for r in ok if m in r["refused"]})
        out["models"][m] = {"peaks": peaks, "rel_error": errors, "refused": refused[0] if refused else None,
                            **{key: stats([e[key] for e in done]) for key in ("rms_pct", "max_pct")}}
    out["realisations"] = [{"live_contacts": sum(p is not None for p in r["peaks"]["dns"]), "errors": r["errors"]}
                           for r in ok]
    out["live_contacts"] = stats([row["live_contacts"] for row in out["realisations"]])
    velocity = [r["velocity_peaks"] for r in ok if r.get("velocity_peaks")]
    if velocity:
        beads = velocity[0]["beads"]
        out["velocity_peaks"] = {"beads": beads, "dns": [stats([v["peaks"][k] for v in velocity])
                                                         for k in range(len(beads))]}
    return out


def terms_ensemble(scene, realisations: int, seed: int = 0, *, profile: str | None = None, out: str | None = None,
                   executor=None, max_workers: int | None = None, progress: bool = False,
                   retry_failed: bool = False) -> dict:
    """The ensemble of a scene with a contact-law term or masses (terms_points, terms_task); the report."""
    points = terms_points(scene, realisations, seed, profile=profile)
    keys = [".".join(k) for k in drawn_keys(scene)]
    res = run_sweep(terms_task, points, out, executor=executor, max_workers=max_workers, progress=progress,
                    retry_failed=retry_failed, label="ensemble")
    return {
        "scene": scene.as_dict(),
        "seed": seed,
        "realisations": realisations,
        "derived_seeds": [{key: derived_seed(seed, rec["params"]["ensemble"]["realisation"], q)
                           for q, key in enumerate(keys)} for rec in res.records],
        "choices": {"profile": points[0]["profile"], "methods": points[0]["methods"], "rtol": scene.dns["rtol"]},
        "failed": [{"realisation": rec["params"]["ensemble"]["realisation"], "error": rec.get("error")}
                   for rec in res.records if rec["status"] != "ok"],
        "statistics": terms_statistics(res.results(), TERMS_MODELS),
        "sweep": res.summary(),
    }


def terms_text(report: dict) -> str:
    """The report of a contact-law or mass ensemble: each model's error per realisation, then per contact the DNS
    peak's mean and spread and each model's mean peak and mean error."""
    from pulsemap.solvers.studies.bifurcation.report import fixed_column

    st = report["statistics"]
    drawn = ", ".join(report["derived_seeds"][0]) if report["derived_seeds"] else "-"
    lines = [f"ensemble of {report['realisations']} realisations of {report['scene']['name']} (random: {drawn}), "
             f"seed {report['seed']}; DNS and {', '.join(st['models'])} as `pulsemap run` runs them"]
    if report["failed"]:
        lines.append(f"  {len(report['failed'])} realisations failed: " + "; ".join(
            f"#{f['realisation']}: {f['error']}" for f in report["failed"][:3]))
    if not st["contacts"]:
        return "\n".join(lines)
    lc = st["live_contacts"]
    lines.append(f"  live contacts per realisation: mean {lc['mean']:.3g}, min {lc['min']:.0f}, max {lc['max']:.0f}")
    shown = []
    for m, row in st["models"].items():
        if row["refused"]:
            lines.append(f"  {m}: refused ({row['refused']})")
            continue
        shown.append(m)
        s = row["rms_pct"]
        if s["n"]:
            lines.append(f"  {m} RMS error of a realisation (percent over its live range): mean {s['mean']:.2f} %"
                         + (f", std {s['std']:.2f} %" if s["std"] is not None else ""))
    lines.append(f"  {'contact':>7s} {'alive':>5s} {'DNS mean':>9s} {'DNS std':>8s} "
                 + " ".join(f"{m:>10s} {'err':>8s}" for m in shown))
    for k, (c, d) in enumerate(zip(st["contacts"], st["dns"])):
        if d["n"] == 0:
            continue
        cells = [f"{fixed_column(st['models'][m]['peaks'][k]['mean'], 10, 5)} {pct(st['models'][m]['rel_error'][k]['mean'])}"
                 for m in shown]
        lines.append(f"  {c:7d} {d['n']:5d} {fixed_column(d['mean'], 9, 5)} {fixed_column(d['std'], 8, 5)} "
                     + " ".join(cells))
    return "\n".join(lines)
