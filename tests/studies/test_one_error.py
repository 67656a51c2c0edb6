"""One error per model: every RMS a user can see (text, JSON errors, --rank, CSV, table row, sweep record,
Result) is the same number, recomputed here from the peaks by the documented rule: percent over the
contacts first_perturbed .. the last whose DNS peak is >= 2 % of the seed peak, a contact without a
model value counting 100 %."""

from __future__ import annotations

import json
import math
import re

import pytest

from pulsemap.solvers.api.result import Result
from pulsemap.solvers.data.scene.overrides import with_sets
from pulsemap.solvers.data.scene import load_scene
from pulsemap.solvers.studies.ranking import add_ranking, label
from pulsemap.solvers.studies.run import run_scene
from pulsemap.solvers.studies.run.report import to_csv, to_text
from pulsemap.solvers.studies.scene_sweep import scene_task, sweep_points
from pulsemap.solvers.studies.table import Column, scene_row

# (scene, contacts, models): damping whose pulse dies inside the range, a softening foundation, a cubic one
CASES = [
    ("fig8-eps0.3", [16, 45], ["map", "longwave", "energy-law"]),
    ("fig6-eps0.3", [16, 40], ["map", "longwave"]),
    ("fig7-eps0.3", [16, 40], ["map", "energy-map"]),
]


def _by_rule(contacts, dns, values, seed_peak):
    """The documented rule, written out independently of studies/errors.py."""
    pairs = [(c, d, v) for c, d, v in zip(contacts, dns, values) if d is not None]
    last = max(c for c, d, _ in pairs if d >= 0.02 * seed_peak)
    rel = [1.0 if v is None else abs(v / d - 1.0) for c, d, v in pairs if c <= last]
    return 100 * math.sqrt(sum(r * r for r in rel) / len(rel)), 100 * max(rel), last


def _csv_rms(csv: str, model: str) -> float:
    """The RMS recomputed from the CSV alone: its live_range rows, an empty model cell counting 100 %."""
    head, *rows = [line.split(",") for line in csv.splitlines()]
    col, dns, live = head.index(model), head.index("dns"), head.index("live_range")
    rel = [1.0 if r[col] == "" else abs(float(r[col]) / float(r[dns]) - 1.0) for r in rows if r[live] == "true"]
    return 100 * math.sqrt(sum(e * e for e in rel) / len(rel))


@pytest.mark.parametrize("name, contacts, models", CASES, ids=[c[0] for c in CASES])
def test_every_rms_a_user_sees_is_the_same_number(name, contacts, models):
    scene = with_sets(load_scene(name), [f"output.contacts={contacts}"])
    res = run_scene(scene, methods=["dns", *models])
    seed = res["seed"]["peak"]
    add_ranking(scene, res)
    res = json.loads(json.dumps(res))  # what --json writes
    text, csv, result = to_text(res), to_csv(res), Result.from_run(res)
    ranked = {r["model"]: r for r in res["ranking"]}
    for model in models:
        err = res["errors"][model]
        rms, mx, last = _by_rule(res["contacts"], res["peaks"]["dns"], res["peaks"][model], seed)
        assert err["unit"] == "percent" and err["live_range"] == [16, last]
        assert err["rms_pct"] == pytest.approx(rms, rel=1e-12) and err["max_pct"] == pytest.approx(mx, rel=1e-12)
        assert result.errors[model] == err
        assert ranked[label(model, res["choices"]["variant"])]["rms_pct"] == err["rms_pct"]
        assert _csv_rms(csv, model) == pytest.approx(err["rms_pct"], rel=1e-12)
        line = next(t for t in text.splitlines() if re.match(rf"\s+{re.escape(model)}\s+vs DNS:", t))
        assert f"RMS {err['rms_pct']:.3g} %, max {err['max_pct']:.3g} % over the live range 16..{last}" in line
        assert f"{label(model, 'paper')} {err['rms_pct']:.3g}" in text  # the ranking line
        assert f"<td>{err['rms_pct']:.3g}</td>" in result._repr_html_()

    row = scene_row(name, columns=[Column(m) for m in models], scene=scene)
    point = sweep_points(scene, ["perturbation.eps=" + str(scene.perturbation.eps)], methods=["dns", *models])[0]
    record = scene_task(point)
    for model in models:
        key = Column(model).key
        assert row["errors"][key] == res["errors"][model] == record["errors"][model]
    assert row["winner"]["rms_pct"] == min(res["errors"][m]["rms_pct"] for m in models)


def test_bench_reports_the_models_with_the_same_error():
    from pulsemap.solvers.studies.bench.lines import model_points
    from pulsemap.solvers.studies.bench.measure import quick_ladder
    from pulsemap.solvers.studies.bench.report import to_csv as bench_csv

    name, contacts, models = CASES[0]
    scene = with_sets(load_scene(name), [f"output.contacts={contacts}"])
    res = run_scene(scene, methods=["dns", *models])
    points = {p.line: p for p in model_points(scene, res, res["peaks"]["dns"], quick_ladder(repeats=1), lambda s: None)}
    for model in models:
        err, point = res["errors"][model], points[f"{model}/exact" + ("/paper" if model == "map" else "")]
        assert point.rms_pct == err["rms_pct"] and point.max_pct == err["max_pct"] and point.error is None
        assert list(point.live_range) == err["live_range"]
    from dataclasses import asdict

    csv = bench_csv([{"scene": name, "points": [asdict(p) for p in points.values()]}]).splitlines()
    head = csv[0].split(",")
    row = next(r.split(",") for r in csv[1:] if r.split(",")[2] == "map/exact/paper")
    assert float(row[head.index("rms_pct")]) == res["errors"]["map"]["rms_pct"]
    assert float(row[head.index("max_pct")]) == res["errors"]["map"]["max_pct"] and row[head.index("max_rel_error")] == ""
