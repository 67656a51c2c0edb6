"""Every named scene runs by its name (the suite's too); a parameter that is an expression of i needs no
beads, like an R containing i."""

from __future__ import annotations

import pytest

from pulsemap.solvers.cli.main import main
from pulsemap.solvers.data.scene.overrides import with_sets
from pulsemap.solvers.data.scene import SceneError, load_scene
from pulsemap.solvers.data.scene.files import suite_scene_names
from pulsemap.solvers.studies.run import run_scene


def test_every_suite_scene_loads_by_name():
    names = suite_scene_names()
    assert "damp-10" in names and len(names) >= 10
    for name in names:
        scene = load_scene(name)
        assert scene.name == name and scene.source == f"suite:{name}"


def test_a_misspelt_suite_name_gets_a_suggestion():
    with pytest.raises(SceneError, match="did you mean the suite scene 'damp-10'"):
        load_scene("damp-1O")


def test_run_a_suite_scene_by_name(capsys):
    assert main(["run", "damp-10", "--methods", "dns", "--set", "output.contacts=[16, 20]", "--quiet"]) == 0
    assert capsys.readouterr().out.startswith("scene damp-10 [output.contacts=[16, 20]]:")  # --set is named


def test_scenes_lists_the_suite(capsys):
    assert main(["scenes"]) == 0
    out = capsys.readouterr().out
    assert "suite scenes" in out and "damp-100" in out


def test_a_parameter_of_i_runs_without_beads_like_r_of_i():
    base = with_sets(load_scene("default"), ["output.contacts=[16, 30]"])
    by_param = run_scene(with_sets(base, ['perturbation.params.mu="1 + 0.01*i"']), methods=["dns", "map"])
    by_r = run_scene(with_sets(base, ["perturbation.R=-mu*(1 + 0.01*i)*v"]), methods=["dns", "map"])
    assert by_param["scene"]["chain"]["beads"] is None
    assert by_param["peaks"]["dns"] == pytest.approx(by_r["peaks"]["dns"], rel=1e-9)
    assert by_param["peaks"]["map"] == pytest.approx(by_r["peaks"]["map"], rel=1e-9)
    uniform = run_scene(base, methods=["dns"])
    assert by_param["peaks"]["dns"][-1] < uniform["peaks"]["dns"][-1]  # mu grows along the chain: more damping
