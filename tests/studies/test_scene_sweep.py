"""pulsemap sweep: a scene over a grid of any scene key (studies/scene_sweep.py)."""

from __future__ import annotations

import pytest

from pulsemap.solvers.cli.main import main
from pulsemap.solvers.data.scene.overrides import with_sets
from pulsemap.solvers.data.scene import SceneError, load_scene
from pulsemap.solvers.studies.run import run_scene
from pulsemap.solvers.studies.scene_sweep import SceneSweepError, parse_over, scene_sweep, sweep_points, to_text


def test_parse_over_ranges_and_lists():
    scene = load_scene("default")
    key, values = parse_over("perturbation.eps=0.05:0.5:10", scene)
    assert key == "perturbation.eps" and len(values) == 10
    assert values[0] == 0.05 and values[-1] == pytest.approx(0.5) and values[1] == pytest.approx(0.1)
    assert parse_over("excitation.velocity=0.5,1,2", scene) == ("excitation.velocity", [0.5, 1, 2])
    assert parse_over("model.variant=paper,1d", scene) == ("model.variant", ["paper", "1d"])


@pytest.mark.parametrize("text, pattern", [
    ("perturbation.esp=0.1:0.2:3", "did you mean 'perturbation.eps'"),
    ("perturbation.eps=0.1:0.2", "A:B:K"),
    ("perturbation.eps=0.1:x:3", "two numbers"),
    ("perturbation.eps=0.1:0.2:0", "K an integer"),
    ("perturbation.eps", "KEY=A:B:K"),
])
def test_bad_over(text, pattern):
    with pytest.raises((SceneSweepError, SceneError), match=pattern):
        parse_over(text, load_scene("default"))


def test_every_point_is_checked_before_anything_runs():
    with pytest.raises(SceneError, match="velocity"):
        sweep_points(load_scene("default"), ["excitation.velocity=1,-1"])


def test_product_grid_and_results_match_run_scene():
    scene = with_sets(load_scene("default"), ["output.contacts=[16, 24]"])
    report = scene_sweep(scene, ["perturbation.eps=0.1,0.3", "excitation.velocity=1,2"], methods=["dns", "map"],
                         max_workers=1)
    assert [p["sets"] for p in report["points"]] == [
        {"perturbation.eps": 0.1, "excitation.velocity": 1}, {"perturbation.eps": 0.1, "excitation.velocity": 2},
        {"perturbation.eps": 0.3, "excitation.velocity": 1}, {"perturbation.eps": 0.3, "excitation.velocity": 2}]
    direct = run_scene(with_sets(scene, ["perturbation.eps=0.3", "excitation.velocity=2"]), methods=["dns", "map"])
    point = report["points"][3]
    assert point["errors"]["map"] == direct["errors"]["map"]  # run's own error, the same deterministic run
    assert point["live_contacts"] == len(direct["dns"]["live_contacts"])
    text = to_text(report)
    assert "in percent" in text and "map max / RMS %" in text  # the order and units of pulsemap table
    err = point["errors"]["map"]
    cell = f"{err['max_pct']:.3g} / {err['rms_pct']:.3g}"
    assert err["max_pct"] > err["rms_pct"] and cell in text.splitlines()[3 + 3]


def test_cli_sweep(capsys):
    assert main(["sweep", "default", "--over", "perturbation.eps=0.1:0.3:2", "--set", "output.contacts=[16, 20]",
                 "--methods", "dns,map", "--workers", "1"]) == 0
    cap = capsys.readouterr()
    assert "perturbation.eps" in cap.out and "2 points run" in cap.out
    assert "[sweep] 1/2 perturbation.eps=0.1: ok" in cap.err


def test_grid_values_and_progress_lines_read_as_the_user_wrote_them(capsys):
    scene = with_sets(load_scene("default"), ["output.contacts=[16, 20]"])
    points = sweep_points(scene, ["perturbation.eps=0.05:0.5:10"], methods=["map"])
    eps = [p["sets"]["perturbation.eps"] for p in points]
    assert eps == [0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.5]  # not 0.15000000000000002
    assert all(abs(e - (0.05 + 0.05 * k)) < 1e-15 for k, e in enumerate(eps))  # the same grid, rounded
    scene_sweep(scene, ["perturbation.eps=0.05:0.5:10"], methods=["map"], max_workers=1, progress=True)
    err = capsys.readouterr().err
    assert "perturbation.eps=0.15: ok" in err and "0000000" not in err
