"""What `pulsemap run` prints and writes: one unit (percent), a legend, the contacts and columns asked
for, the ranking next to the paper's map, and the DNS's arrival times, speeds, energies, snapshots."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pulsemap.solvers.cli.main import main
from pulsemap.solvers.data.scene.overrides import with_sets
from pulsemap.solvers.data.scene import load_scene
from pulsemap.solvers.studies.ranking import add_ranking, rank_models
from pulsemap.solvers.studies.run import run_scene
from pulsemap.solvers.studies.run.report import LEGEND, MAX_ROWS, to_csv, to_text


@pytest.fixture(scope="module")
def short():
    scene = with_sets(load_scene("default"), ["output.contacts=[16, 30]"])
    return scene, run_scene(scene, methods=["dns", "map"])


def _table_rows(text: str) -> list[list[str]]:
    lines = text.splitlines()
    start = next(k for k, line in enumerate(lines) if line.split()[:1] == ["contact"])
    rows = []
    for line in lines[start + 1:]:
        parts = line.split()
        if not parts or not parts[0].isdigit():
            break
        rows.append(parts)
    return [lines[start].split()] + rows


def test_errors_in_percent_with_a_legend(short):
    _, res = short
    text = to_text(res)
    assert LEGEND in text and "leading-edge maximum of delta_i = x_i - x_(i+1)" in text
    err = res["errors"]["map"]
    a, b = err["live_range"]
    assert f"RMS {err['rms_pct']:.3g} %, max {err['max_pct']:.3g} % over the live range {a}..{b}" in text
    lines = [line for line in text.splitlines() if "vs DNS:" in line]
    assert len(lines) == 1 and lines[0].count("RMS") == 1  # one error per model, no second window


def test_only_the_columns_asked_for_and_every_contact(short):
    _, res = short
    table = _table_rows(to_text(res))
    assert table[0] == ["contact", "dns", "map"]  # no longwave column: it was not asked for
    assert [int(r[0]) for r in table[1:]] == list(range(16, 31))


def test_long_runs_are_thinned_with_a_note_and_all_shows_all():
    scene = with_sets(load_scene("fig8-eps0.1"), ["output.contacts=[16, 80]"])
    res = run_scene(scene, methods=["map"])  # map only: a value at every contact
    text = to_text(res)
    rows = _table_rows(text)[1:]
    assert len(rows) <= MAX_ROWS and int(rows[1][0]) - int(rows[0][0]) == 2
    assert "(every 2nd contact of 65: --all for all" in text
    assert len(_table_rows(to_text(res, every=1))) - 1 == 65


def test_ranking_matches_each_model_run_alone(short):
    scene, res = short
    ranking = rank_models(scene, res)
    names = [r["model"] for r in ranking]
    assert {"map/paper", "map/corrected", "map/1d", "longwave", "energy-law"} <= set(names)
    assert [r["rms_pct"] for r in ranking] == sorted(r["rms_pct"] for r in ranking)
    alone = run_scene(scene, methods=["dns", "map"], variant="1d")
    entry = next(r for r in ranking if r["model"] == "map/1d")
    assert {k: entry[k] for k in alone["errors"]["map"]} == alone["errors"]["map"]
    assert entry["peaks"] == alone["peaks"]["map"]


def test_rank_shows_the_best_model_in_every_output(capsys, tmp_path):
    """--rank: the best model's peaks are in the text table, the CSV, the plot and the JSON, with what it is."""
    pytest.importorskip("matplotlib")
    files = {k: tmp_path / f"run.{k}" for k in ("json", "csv", "png")}
    assert main(["run", "default", "--quiet", "--rank", "--set", "output.contacts=[16, 40]", "--json", str(files["json"]),
                 "--csv", str(files["csv"]), "--plot", str(files["png"])]) == 0
    out = capsys.readouterr().out
    ranking_line = next(line for line in out.splitlines() if "ranking against this DNS" in line)
    best = ranking_line.split(": ", 1)[1].split(",")[0].rsplit(" ", 1)[0]
    data = json.loads(files["json"].read_text())
    assert data["best"]["model"] == best == data["ranking"][0]["model"]
    column = data["best"]["column"]
    assert data["peaks"][column] is not None and data["errors"][column]["rms_pct"] == data["ranking"][0]["rms_pct"]
    assert f"  {column}: {data[column]['model']}" in out  # one line on what it is
    header = _table_rows(out)[0]
    assert header[:4] == ["contact", "dns", "map", "longwave"]
    assert column in ("map", "longwave") or header[-1] == column
    assert column in files["csv"].read_text().splitlines()[0].split(",")
    from pulsemap.solvers.data.plotting import figures, peaks_figure

    labels = [line.get_label() for line in peaks_figure(data, figures()).axes[0].get_lines()]
    assert sum(label.endswith("(best of the ranking)") for label in labels) == 1
    if best != "map/paper":
        assert "first-order theory in eps" in out and f"{best} does best here" in out


def test_the_default_run_ranks_nothing_and_says_how(short):
    _, res = short
    assert "ranking" not in res and "best" not in res
    text = to_text(res)
    if res["errors"]["map"]["rms_pct"] > 20:
        assert "`pulsemap run --rank` ranks every model" in text


def test_rank_without_the_dns_is_a_usage_error(capsys):
    assert main(["run", "default", "--methods", "map", "--rank", "--quiet"]) == 2
    assert "add dns to the methods" in capsys.readouterr().err


def test_add_ranking_adds_a_best_the_run_did_not_compute(short):
    scene, res = short
    res = json.loads(json.dumps(res))
    add_ranking(scene, res)
    best = res["best"]
    if best["model"] == "map/paper":
        assert best["column"] == "map"
    else:
        assert res["peaks"][best["column"]] == rank_models(scene, res)[0]["peaks"]
        assert best["column"] in to_csv(res).splitlines()[0].split(",")


def test_csv_has_arrival_times_and_speeds(short):
    _, res = short
    lines = to_csv(res).splitlines()
    head = lines[0].split(",")
    assert head[:3] == ["contact", "dns", "map"] and "dns_arrival_time" in head and "dns_speed" in head
    t = np.array([float(line.split(",")[head.index("dns_arrival_time")]) for line in lines[1:]])
    speed = np.array([float(line.split(",")[head.index("dns_speed")]) for line in lines[1:]])
    assert np.all(np.diff(t) > 0)
    assert speed[1:-1] == pytest.approx(2 / (t[2:] - t[:-2]), rel=1e-12)  # contacts per unit time


def test_unperturbed_run_reports_its_energy_drift(capsys):
    assert main(["run", "default", "--set", "perturbation.R=0", "--methods", "dns", "--set", "output.contacts=[16, 40]",
                 "--json", "-", "--snapshots", "20,30", "--quiet"]) == 0
    out = json.loads(capsys.readouterr().out)
    dns = out["dns"]
    assert dns["energy_drift"] is not None and dns["energy_drift"] < 1e-6
    assert dns["total_energy"] == pytest.approx([0.5] * 25, rel=1e-6)  # v0^2/2, conserved
    snaps = {s["contact"]: s for s in dns["snapshots"]}
    assert set(snaps) == {20, 30}
    s = snaps[30]
    assert s["strains"][s["contacts"].index(30)] == pytest.approx(out["peaks"]["dns"][30 - 16], rel=1e-10)
    assert s["time"] == pytest.approx(dns["arrival_times"][30 - 16], rel=1e-14)


def test_bad_snapshots_and_nothing_ran_are_errors(capsys, tmp_path):
    assert main(["run", "default", "--snapshots", "200", "--quiet"]) == 2
    assert "snapshot contact 200" in capsys.readouterr().err
    assert main(["run", "default", "--set", "perturbation.R=-mu*sin(v)", "--methods", "map,longwave", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("pulsemap: error: nothing ran: map:") and err.count("\n") == 1
