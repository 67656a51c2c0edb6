"""--set key=value (data/overrides.py): any scene key from the command line, checked like a file."""

from __future__ import annotations

import json

import pytest

from conftest import scene_toml, write_scene
from pulsemap.solvers.cli.main import main
from pulsemap.solvers.data.overrides import parse_assignment, scene_keys, with_sets
from pulsemap.solvers.data.scene import SceneError, load_scene


def test_a_set_equals_the_same_value_in_the_file(tmp_path):
    base = load_scene(str(write_scene(tmp_path, scene_toml(eps=0.1), "a.toml")))
    edited = load_scene(str(write_scene(tmp_path, scene_toml(eps=0.25, contacts=(16, 22)), "b.toml")))
    got = with_sets(base, ["perturbation.eps=0.25", "output.contacts=[16, 22]"])
    assert got.as_dict() | {"source": None, "name": None} == edited.as_dict() | {"source": None, "name": None}
    assert got.name == f"{base.name} [perturbation.eps=0.25, output.contacts=[16, 22]]"  # says it was changed
    assert with_sets(base, ["name=mine", "perturbation.eps=0.25"]).name == "mine"


def test_values_are_toml_or_text():
    assert parse_assignment("perturbation.eps=0.2") == ("perturbation.eps", 0.2)
    assert parse_assignment("output.contacts=[16, 40]") == ("output.contacts", [16, 40])
    assert parse_assignment("perturbation.R=-mu*v") == ("perturbation.R", "-mu*v")
    assert parse_assignment("model.profile=pade") == ("model.profile", "pade")
    assert parse_assignment("perturbation.params.k={uniform = [0, 1], seed = 3}") == (
        "perturbation.params.k", {"uniform": [0, 1], "seed": 3})


def test_r_and_a_new_parameter_together():
    scene = with_sets(load_scene("default"), ["perturbation.R=-mu*v - a*u", "perturbation.params.a=0.5"])
    assert scene.perturbation.text == "-mu*v - a*u"
    assert float(scene.perturbation.params["a"]) == 0.5


@pytest.mark.parametrize("text, pattern", [
    ("perturbation.esp=0.2", "did you mean 'perturbation.eps'"),
    ("excitation.velocty=2", "did you mean 'excitation.velocity'"),
    ("eps=0.2", "unknown scene key"),
    ("perturbation.eps", "expected KEY=VALUE"),
    ("excitation.velocity=-1", r"--set excitation.velocity=-1: .*velocity"),
    ("perturbation.params.nu=1", "nu"),  # R does not use it: parse_scene says so
])
def test_bad_sets_are_one_line_errors(text, pattern):
    with pytest.raises(SceneError, match=pattern) as info:
        with_sets(load_scene("default"), [text])
    assert "\n" not in str(info.value)


def test_every_scene_file_key_is_settable():
    keys = scene_keys(load_scene("default"))
    for key in ("perturbation.eps", "excitation.velocity", "chain.exponent", "output.contacts", "dns.rtol",
                "perturbation.params.mu", "model.variant"):
        assert key in keys


def test_run_with_sets(capsys):
    assert main(["run", "default", "--set", "perturbation.eps=0.2", "--set", "output.contacts=[16, 20]",
                 "--methods", "dns,map", "--json", "-", "--quiet"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["contacts"] == [16, 17, 18, 19, 20]
    assert out["scene"]["perturbation"]["eps"] == 0.2


@pytest.mark.parametrize("command", [["run", "default"], ["table", "default"], ["bench", "default", "--quick"],
                                     ["bifurcation", "vdp-mu3-v2.3", "--param", "mu", "--range", "1", "2"],
                                     ["ensemble", "fig13-seed1", "--realisations", "2"],
                                     ["sweep", "default", "--over", "perturbation.eps=0.1:0.2:2"]])
def test_every_scene_command_refuses_an_unknown_key_before_running(capsys, command):
    assert main(command + ["--set", "perturbation.esp=0.2"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "did you mean 'perturbation.eps'" in err
