"""Every reduced model against one run's DNS, best first (what ``pulsemap run`` shows next to the
models a scene asks for, so the paper's map is never the only number a user sees).

The DNS of the run is reused (``run_scene(reuse_dns=...)``), so the ranking costs only the models:
milliseconds each once their generated modules exist. The measure is the table's (studies/table.py):
RMS relative error over the live range (studies/live_range.py: from first_perturbed to the last
contact whose DNS peak is >= 2 % of the seed's), a model that has ended there counting 100 %.
"""

from __future__ import annotations

from pulsemap.solvers.data.scene import VARIANTS, Scene
from pulsemap.solvers.studies.methods import MODELS

#: The map in every variant, then the laws and balances (the table's exact-profile columns).
OTHER_MODELS = tuple(m for m in MODELS if m != "map")


def label(method: str, variant: str | None = None) -> str:
    return f"map/{variant}" if method == "map" else method


def rank_models(scene: Scene, result: dict) -> list[dict]:
    """[{model, rms_pct, max_pct, peaks}] for every model defined for this R, least RMS first; []
    without a DNS. Models refused for this R (e.g. momentum with a foundation term) are left out."""
    from pulsemap.solvers.studies.run import RunError, run_scene

    if (result.get("peaks") or {}).get("dns") is None or not result.get("dns"):
        return []
    profile = result["choices"]["profile"]
    runs = []
    for variant in VARIANTS:
        runs.append(({"map": variant}, ["map"], variant))
    runs.append(({}, list(OTHER_MODELS), None))
    rows = []
    for names, methods, variant in runs:
        try:
            res = run_scene(scene, methods=methods, profile=profile, variant=variant or result["choices"]["variant"],
                            reuse_dns=result)
        except (RunError, ValueError):  # a model this R cannot have: it is not ranked
            continue
        for method, err in res["errors"].items():
            score = err.get("live") or {}  # the table's measure: the live range (studies/live_range.py)
            if score.get("rms_rel_all") is None:
                continue
            rows.append({"model": label(method, names.get(method)), "rms_pct": 100.0 * score["rms_rel_all"],
                         "max_pct": 100.0 * score["max_rel_all"], "live_contacts": score.get("contacts"),
                         "peaks": res["peaks"][method]})
    rows.sort(key=lambda r: r["rms_pct"])
    return rows
