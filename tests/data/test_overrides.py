"""--set key=value (data/scene/overrides.py): any scene key from the command line, checked like a file."""

from __future__ import annotations

import json

import pytest

from conftest import scene_toml, write_scene
from pulsemap.solvers.cli.main import main
from pulsemap.solvers.data.scene.overrides import parse_assignment, scene_keys, with_sets
from pulsemap.solvers.data.scene import SceneError, load_scene, with_overrides


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


def _five_ways(tmp_path, dotted: dict, fields: dict, toml_edit):
    """The same change through --set, pulsemap.scene(**kw), with_overrides, a TOML file and a dict."""
    import pulsemap
    from pulsemap.solvers.data.scene import parse_scene

    base = load_scene("fig8-eps0.3")
    data = base.as_dict()
    toml_edit(data)
    lines = [f"{k}={json.dumps(v)}" for k, v in dotted.items()] + ["name=x"]
    return {
        "set": with_sets(base, lines),
        "api": pulsemap.scene("fig8-eps0.3", name="x", **dotted),
        "fields": with_overrides(base, name="x", **fields),
        "dict": pulsemap.scene({**data, "name": "x"}),
        "toml": parse_scene({**data, "name": "x"}, base.source),
    }


@pytest.mark.parametrize("dotted, fields, edit", [
    ({"perturbation.eps": 0.2, "output.contacts": [16, 40]}, {"eps": 0.2, "contacts": (16, 40)},
     lambda d: (d["perturbation"].update(eps=0.2), d["output"].update(contacts=[16, 40]))),
    ({"perturbation.R": "-mu*v - k*u^3", "perturbation.params.k": 0.5}, {"R": "-mu*v - k*u^3", "params": {"mu": 1.0, "k": 0.5}},
     lambda d: d["perturbation"].update(R="-mu*v - k*u^3", params={"mu": 1.0, "k": 0.5})),
    ({"perturbation.R": "-v"}, {"R": "-v"}, lambda d: d["perturbation"].update(R="-v", params={})),  # mu dropped
    ({"dns.rtol": 1e-8, "chain.beads": 200}, {"dns": {"rtol": 1e-8}, "beads": 200},
     lambda d: (d["dns"].update(rtol=1e-8), d["chain"].update(beads=200))),
])
def test_one_override_gives_one_scene_through_every_entry_point(tmp_path, dotted, fields, edit):
    got = _five_ways(tmp_path, dotted, fields, edit)
    want = got["toml"]
    for way, scene in got.items():
        assert scene == want, way
        assert scene.as_dict() == want.as_dict(), way
    assert got["set"].perturbation.params == got["api"].perturbation.params


def test_an_unknown_key_is_refused_the_same_way_everywhere():
    import pulsemap

    base = load_scene("default")
    for call in (lambda: with_sets(base, ["perturbation.esp=0.2"]),
                 lambda: pulsemap.scene("default", **{"perturbation.esp": 0.2})):
        with pytest.raises(SceneError, match="perturbation.eps"):
            call()
