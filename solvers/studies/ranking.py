"""Every reduced model against one run's DNS, best first (``pulsemap run --rank``,
``pulsemap.run(..., rank=True)``), so the paper's map is not the only number a user sees.

The DNS of the run is reused (``run_scene(reuse_dns=...)``), so the ranking costs only the models.
The measure is every output's (studies/errors.py: RMS relative error in percent over the live
range, a model that has ended there counting 100 %). The best model joins the run's ``peaks`` and
``errors`` (so the text, CSV, plot and JSON show it) with a line saying what it is.
"""

from __future__ import annotations

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.data.scene import VARIANTS, Scene
from pulsemap.solvers.studies.methods import MODELS

#: The map in every variant, then the laws and balances (the table's exact-profile columns).
OTHER_MODELS = tuple(m for m in MODELS if m != "map")


def label(method: str, variant: str | None = None) -> str:
    return f"map/{variant}" if method == "map" else method


def title(model: str) -> str:
    """What a ranked model is, in one line ('map/1d': the map's title with its variant)."""
    from pulsemap.solvers.studies.run.models import RUNNERS  # the model table (loads the models' modules)

    method, _, variant = model.partition("/")
    return RUNNERS[method].title + (f", variant {variant}" if variant else "")


def rank_models(scene: Scene, result: dict) -> list[dict]:
    """[{model, title, the error (studies/errors.py), peaks, info}] for every model defined for this R,
    least RMS first; [] without a DNS. Models refused for this R (e.g. momentum with a foundation
    term) are left out."""
    from pulsemap.solvers.studies.run import run_scene

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
        except PulsemapError:  # a model this R cannot have: it is not ranked
            continue
        for method, err in res["errors"].items():
            if err["rms_pct"] is None:
                continue
            model = label(method, names.get(method))
            rows.append({"model": model, "title": title(model), **err, "peaks": res["peaks"][method],
                         "info": res.get(method)})
    rows.sort(key=lambda r: r["rms_pct"])
    return rows


def shown_as(result: dict, model: str) -> str | None:
    """The run's own column that already is ``model`` ('map/paper' is 'map' in a paper-variant run), or None."""
    methods = result["choices"]["methods"]
    if model in methods:
        return model
    if model == f"map/{result['choices']['variant']}" and "map" in methods:
        return "map"
    return None


def add_ranking(scene: Scene, result: dict) -> None:
    """Rank every model against the run's DNS into ``result["ranking"]`` (without peaks) and name the
    best under ``result["best"]``; a best model the run did not compute joins its ``peaks``,
    ``errors`` and per-model entries under its ranking name (e.g. 'relaxed', 'map/1d')."""
    rows = rank_models(scene, result)
    result["ranking"] = [{k: v for k, v in r.items() if k not in ("peaks", "info")} for r in rows]
    if not rows:
        return
    best = rows[0]
    column = shown_as(result, best["model"])
    if column is None:
        column = best["model"]
        result["peaks"][column] = best["peaks"]
        result["errors"][column] = {k: best[k] for k in ("unit", "rms_pct", "max_pct", "live_range", "compared",
                                                         "missing")}
        result[column] = {**(best["info"] or {}), "model": best["title"], "added_by": "ranking (best model)"}
    result["best"] = {"model": best["model"], "column": column, "title": best["title"]}
