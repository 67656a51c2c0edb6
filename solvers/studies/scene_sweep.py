"""Generic sweeps: run a scene over a grid of values of any scene key (``pulsemap sweep``).

``--over perturbation.eps=0.05:0.5:10`` (10 values from 0.05 to 0.5, ends included) or
``--over excitation.velocity=0.5,1,2`` (a list); several ``--over`` make the product grid. Each
point is the scene with those keys set (data/scene/overrides.py, checked like a scene file before
anything runs), run by ``run_scene`` on sweep.run_sweep (process pool, Dask, resumable --out).
The report has, per point, the values set, the DNS's live contacts and stop reason, and each
model's error against the DNS as ``run`` reports it (studies/errors.py: RMS and max in percent over
the live range). A value of A:B:K is rounded to 12 significant digits, so 0.05:0.5:10 gives 0.15
(as a user writes it), not 0.15000000000000002.
"""

from __future__ import annotations

import itertools
from typing import Any, Mapping, Sequence

import numpy as np

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.data.scene.overrides import check_key, parse_assignment, with_sets
from pulsemap.solvers.data.scene import Scene, SceneError, parse_scene

MAX_POINTS = 10_000
#: What a point's errors are (part of its key: records of an older measure are computed again).
ERRORS = "percent over the live range"


class SceneSweepError(PulsemapError):
    """A sweep that cannot be run as asked."""


def parse_over(text: str, scene: Scene) -> tuple[str, list]:
    """'KEY=A:B:K' (K values from A to B, ends included) or 'KEY=v1,v2,...' -> (key, values)."""
    if not isinstance(text, str) or "=" not in text:
        raise SceneSweepError(f"--over {text!r}: expected KEY=A:B:K or KEY=v1,v2,... (e.g. perturbation.eps=0.05:0.5:10)")
    key, spec = (part.strip() for part in text.split("=", 1))
    check_key(key, scene)
    parts = spec.split(":")
    if len(parts) == 3:
        try:
            a, b, k = float(parts[0]), float(parts[1]), int(parts[2])
        except ValueError:
            raise SceneSweepError(f"--over {text}: A:B:K needs two numbers and an integer count, got {spec!r}") from None
        if not (np.isfinite(a) and np.isfinite(b)) or not 1 <= k <= MAX_POINTS:
            raise SceneSweepError(f"--over {text}: A and B must be finite and K an integer from 1 to {MAX_POINTS}")
        values = [float(f"{v:.12g}") for v in np.linspace(a, b, k)] if k > 1 else [a]
        return key, values
    if len(parts) != 1 or not spec:
        raise SceneSweepError(f"--over {text}: expected KEY=A:B:K or KEY=v1,v2,...")
    return key, [parse_assignment(f"{key}={item.strip()}")[1] for item in spec.split(",") if item.strip()]


def sweep_points(scene: Scene, overs: Sequence[str], methods: Sequence[str] | None = None) -> list[dict]:
    """The plain points of the grid; every point's scene is built (and checked) here, before any run."""
    if not overs:
        raise SceneSweepError("give at least one --over KEY=A:B:K (e.g. --over perturbation.eps=0.05:0.5:10)")
    axes = [parse_over(text, scene) for text in overs]
    keys = [k for k, _ in axes]
    if len(set(keys)) != len(keys):
        raise SceneSweepError(f"--over: a key is given twice ({', '.join(keys)})")
    total = int(np.prod([len(v) for _, v in axes]))
    if total > MAX_POINTS:
        raise SceneSweepError(f"--over: {total} points is more than {MAX_POINTS}: use fewer values")
    points = []
    for combo in itertools.product(*(values for _, values in axes)):
        sets = dict(zip(keys, combo))
        point_scene = with_sets(scene, list(sets.items()))
        points.append({"scene": point_scene.as_dict(), "sets": sets,
                       "methods": list(methods) if methods else list(point_scene.methods), "errors": ERRORS})
    return points


def scene_task(point: Mapping[str, Any]) -> dict:
    """Run one point (in a worker): run_scene's errors and the DNS's outcome, numbers only."""
    from pulsemap.solvers.studies.run import run_scene

    scene = parse_scene(point["scene"], point["scene"].get("source") or "sweep")
    res = run_scene(scene, methods=point["methods"])
    dns = res.get("dns") or {}
    return {
        "live_contacts": len(dns.get("live_contacts", [])) if dns else None,
        "stop_reason": dns.get("stop_reason"),
        "errors": res["errors"],  # studies/errors.py: what run reports
        "warnings": res["warnings"],
        "timings_s": res["timings_s"],
    }


def scene_sweep(scene: Scene, overs: Sequence[str], *, methods: Sequence[str] | None = None,
                out: str | None = None, executor=None, max_workers: int | None = None,
                progress: bool = False, retry_failed: bool = False) -> dict:
    """Run ``scene`` at every point of the grid; the report (JSON-serialisable)."""
    from pulsemap.solvers.studies.sweep import run_sweep

    try:
        points = sweep_points(scene, overs, methods)
    except SceneError as exc:
        raise SceneSweepError(str(exc)) from None
    res = run_sweep(scene_task, points, out, executor=executor, max_workers=max_workers, progress=progress,
                    retry_failed=retry_failed, label="sweep",
                    name_of=lambda p: ", ".join(f"{k}={v}" for k, v in p["sets"].items()))
    rows = []
    for rec in res.records:
        row = {"sets": rec["params"]["sets"], "status": rec["status"]}
        if rec["status"] == "ok":
            row.update(rec["result"])
        else:
            row["error"] = rec.get("error")
        rows.append(row)
    return {"scene": scene.as_dict(), "over": list(overs), "keys": list(points[0]["sets"]),
            "methods": points[0]["methods"], "points": rows, "computed": res.computed, "skipped": res.skipped,
            "failed": res.failed, "wall_s": res.wall_s, "executor": res.executor}


def to_text(report: dict) -> str:
    """One line per point: the values set, live contacts, each model's max / RMS error (%), as ``table`` orders them."""
    from pulsemap.solvers.studies.errors import DEFINITION

    keys = report["keys"]
    models = [m for m in report["methods"] if m != "dns"]
    head = [k.removeprefix("perturbation.params.") for k in keys] + ["alive", *(f"{m} max / RMS %" for m in models)]
    lines = [f"sweep of scene {report['scene']['name']} over {', '.join(report['over'])}",
             f"errors: max / RMS of {DEFINITION}; alive: how many contacts the DNS's primary pulse reached",
             "  ".join(f"{h:>18s}" for h in head)]
    for row in report["points"]:
        cells = [_fmt(row["sets"][k]) for k in keys]
        if row["status"] != "ok":
            lines.append("  ".join(f"{c:>18s}" for c in cells) + f"  FAILED: {row.get('error')}")
            continue
        cells.append("-" if row.get("live_contacts") is None else str(row["live_contacts"]))
        for m in models:
            e = row["errors"].get(m)
            cells.append("-" if not e or e.get("rms_pct") is None else f"{e['max_pct']:.3g} / {e['rms_pct']:.3g}")
        lines.append("  ".join(f"{c:>18s}" for c in cells))
    lines.append(f"{report['computed']} points run, {report['skipped']} from the --out file, {report['failed']} failed "
                 f"({report['wall_s']:.1f} s, {report['executor']})")
    return "\n".join(lines)


def _fmt(v: Any) -> str:
    return f"{v:.6g}" if isinstance(v, float) else str(v)
