"""Scene files: built-in scenes, round trips, and a catalogue of bad input (solvers/scene.py)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from conftest import scene_toml, write_scene
from pulsemap.solvers.data.scene import (
    DEFAULT_SCENE,
    Scene,
    SceneError,
    builtin_scene_path,
    builtin_scenes,
    load_scene,
    parse_scene,
    with_overrides,
)

EXPECTED_BUILTINS = sorted(
    [f"fig6-eps{e}" for e in ("0.1", "0.3", "0.5", "1")]
    + [f"fig7-eps{e}" for e in ("0.1", "0.3", "1")]
    + [f"fig8-eps{e}" for e in ("0.1", "0.3", "0.5", "1")]
    + [f"vdp-mu{mu}-v{v}" for mu in ("3", "1") for v in ("2.3", "0.3")]
    + [f"fig13-seed{s}" for s in (1, 2, 3, 4)]
)

GOOD = scene_toml("damping-eps0.3", beads=140, eps=0.3, contacts=(16, 120))


def edit(old: str, new: str) -> str:
    assert old in GOOD, old
    return GOOD.replace(old, new)


# --------------------------------------------------------------------------- built-ins


def test_builtin_names():
    assert builtin_scenes() == EXPECTED_BUILTINS


@pytest.mark.parametrize("name", EXPECTED_BUILTINS)
def test_builtin_loads_and_round_trips(name):
    scene = load_scene(name)
    assert scene.name == name
    assert scene.source == f"builtin:{name}"
    assert scene.first_perturbed == 16 and scene.exponent == 1.5
    assert scene.contacts[0] == 16 and scene.contacts[1] > 16
    text = builtin_scene_path(name).read_text(encoding="utf-8")
    assert text.startswith("# Paper Fig"), "each built-in names the figure it reproduces"
    data = json.loads(json.dumps(scene.as_dict()))
    again = parse_scene(data, scene.source)
    assert again == scene
    assert again.as_dict() == scene.as_dict()


def test_builtin_physics():
    fig6 = load_scene("fig6-eps0.5")
    assert fig6.perturbation.text == "alpha*u" and fig6.perturbation.eps == 0.5
    assert fig6.perturbation.params["alpha"] == -1.0
    assert load_scene("fig7-eps1").perturbation.params["beta"] == -1.0
    vdp = load_scene("vdp-mu3-v0.3")
    assert vdp.velocity == 0.3 and vdp.perturbation.eps == 0.1 and vdp.perturbation.params["mu"] == 3.0
    assert vdp.perturbation.text == "-(u - mu*(1 - u^2)*v)"  # erratum 6, docs/errata.rst
    fig13 = load_scene("fig13-seed3")
    assert fig13.beads == 140 and "longwave" not in fig13.methods
    k = fig13.perturbation.bead_values("k", fig13.beads)
    assert k.shape == (140,) and 0 <= k.min() and k.max() <= 1
    assert not np.array_equal(k, load_scene("fig13-seed4").perturbation.bead_values("k", 140))


def test_default_alias():
    scene = load_scene("default")
    assert scene == load_scene(DEFAULT_SCENE) and scene.name == "fig8-eps0.3"
    assert scene.beads is None and scene.methods == ("map", "longwave", "dns")


def test_file_scene_and_defaults(tmp_path):
    path = write_scene(
        tmp_path,
        '[excitation]\nvelocity = 2\n[perturbation]\nR = "-k*u"\neps = 1\n'
        '[perturbation.params]\nk = "1 + 0.01*i"\n[output]\ncontacts = [20, 30]\nmethods = ["dns", "map"]\n',
        "mine.toml",
    )
    scene = load_scene(str(path))
    assert scene.name == "mine" and scene.source == str(path)
    assert (scene.beads, scene.exponent, scene.first_perturbed) == (None, 1.5, 16)
    assert scene.velocity == 2.0 and isinstance(scene.velocity, float)
    assert scene.methods == ("map", "dns")  # canonical order
    assert dict(scene.dns) == {"rtol": 1e-10, "atol": 1e-12, "method": "auto"}
    assert (scene.profile, scene.variant) == ("exact", "paper")
    assert scene.as_dict()["perturbation"]["params"] == {"k": "1 + 0.01*i"}
    assert parse_scene(json.loads(json.dumps(scene.as_dict())), scene.source) == scene
    assert hash(scene) == hash(parse_scene(scene.as_dict(), scene.source))


def test_model_and_dns_tables(tmp_path):
    text = GOOD + '[model]\nprofile = "pade"\nvariant = "1d"\n[dns]\nrtol = 1e-8\nmethod = "Radau"\n'
    scene = load_scene(str(write_scene(tmp_path, text)))
    assert (scene.profile, scene.variant) == ("pade", "1d")
    assert dict(scene.dns) == {"rtol": 1e-8, "atol": 1e-12, "method": "Radau"}


def test_with_overrides():
    scene = load_scene("fig8-eps0.3")
    other = with_overrides(scene, eps=0.5, beads=200, dns={"rtol": 1e-6})
    assert other.perturbation.eps == 0.5 and other.beads == 200
    assert dict(other.dns) == {"rtol": 1e-6, "atol": 1e-12, "method": "auto"}
    assert scene.perturbation.eps == 0.3  # unchanged
    assert with_overrides(scene, methods=["dns", "map"]).methods == ("map", "dns")
    with pytest.raises(SceneError, match="beyond a chain of 100 beads"):
        with_overrides(scene, beads=100)
    with pytest.raises(SceneError, match="did you mean 'beads'"):
        with_overrides(scene, bead=200)
    with pytest.raises(SceneError, match="velocity"):
        with_overrides(scene, velocity=float("nan"))
    with pytest.raises(SceneError, match="R\\(0,0\\)"):
        with_overrides(scene, R="1 - mu*v")


# --------------------------------------------------------------------------- bad input

BAD = [
    ("toml syntax", GOOD.replace("eps = 0.3", "eps = = 0.3"), ["line 10", "TOML syntax error"]),
    ("unquoted string", GOOD.replace('R = "-mu*v"', "R = -mu*v"), ["line 9"]),
    ("misspelt key", edit("exponent = 1.5", "expnent = 1.5"), ["'expnent'", "did you mean 'exponent'?"]),
    ("misspelt top key", "nmae = 'x'\n" + GOOD.replace('name = "damping-eps0.3"\n', ""), ["'nmae'", "'name'"]),
    ("unknown table", GOOD + "[chian]\nbeads = 3\n", ["[chian]", "did you mean [chain]?"]),
    ("unknown sub-table", GOOD + "[output.extra]\nx = 1\n", ["[output.extra]"]),
    ("table as value", "excitation = 1\n" + GOOD.replace("[excitation]\nvelocity = 1.0\n", ""), ["[excitation]", "table"]),
    ("top key inside a table", GOOD.replace("[excitation]\nvelocity = 1.0\n", "excitation = 1\n"),
     ["'excitation' is inside [chain]", "[excitation]"]),
    ("velocity string", edit("velocity = 1.0", 'velocity = "1.0"'), ["velocity", "number", "remove the quotes"]),
    ("velocity bool", edit("velocity = 1.0", "velocity = true"), ["velocity", "boolean"]),
    ("velocity zero", edit("velocity = 1.0", "velocity = 0"), ["velocity", "> 0"]),
    ("eps nan", edit("eps = 0.3", "eps = nan"), ["eps", "not finite"]),
    ("velocity inf", edit("velocity = 1.0", "velocity = inf"), ["velocity", "not finite"]),
    ("param inf", edit("mu = 1.0", "mu = -inf"), ["mu", "not finite"]),
    ("eps bool", edit("eps = 0.3", "eps = false"), ["eps", "boolean"]),
    ("beads 0", edit("beads = 140", "beads = 0"), ["beads = 0", ">= 3"]),
    ("beads -5", edit("beads = 140", "beads = -5"), ["beads = -5", ">= 3"]),
    ("beads 2.5", edit("beads = 140", "beads = 2.5"), ["beads", "integer", "2.5"]),
    ("beads bool", edit("beads = 140", "beads = true"), ["beads", "boolean"]),
    ("exponent 1", edit("exponent = 1.5", "exponent = 1"), ["exponent", "> 1"]),
    ("first_perturbed 1", edit("first_perturbed = 16", "first_perturbed = 1"), ["first_perturbed = 1", ">= 2"]),
    ("contacts beyond chain", edit("contacts = [16, 120]", "contacts = [16, 200]"),
     ["contact 200 is beyond a chain of 140 beads (last contact 139)", "raise beads or lower contacts"]),
    ("contacts reversed", edit("contacts = [16, 120]", "contacts = [120, 16]"), ["[120, 16]", "reversed"]),
    ("contacts one number", edit("contacts = [16, 120]", "contacts = 16"), ["contacts", "[first, last]"]),
    ("contacts floats", edit("contacts = [16, 120]", "contacts = [16.0, 120]"), ["contacts first", "integer"]),
    ("contact before first_perturbed", edit("contacts = [16, 120]", "contacts = [10, 120]"),
     ["contacts start at 10", "first_perturbed = 16", "seeded by contact 15"]),
    ("unknown method", edit('"longwave"', '"longwav"'), ["'longwav'", "did you mean 'longwave'?"]),
    ("no methods", edit('methods = ["map", "longwave", "dns"]', "methods = []"), ["methods", "empty"]),
    ("dns method", GOOD + '[dns]\nmethod = "dop853"\n', ["'dop853'", "did you mean 'DOP853'?"]),
    ("dns rtol", GOOD + "[dns]\nrtol = -1e-8\n", ["rtol", "out of range"]),
    ("unknown profile", GOOD + '[model]\nprofile = "padé"\n', ["profile", "'padé'", "exact, pade"]),
    ("unknown variant", GOOD + '[model]\nvariant = "papper"\n', ["variant", "did you mean 'paper'?"]),
    ("per-bead list wrong length", edit("mu = 1.0", "mu = [1.0, 2.0, 3.0]"), ["'mu'", "3 per-bead values", "140 beads"]),
    ("per-bead list without beads", edit("beads = 140\n", "").replace("mu = 1.0", "mu = [1.0, 2.0]"),
     ["'mu'", "set [chain] beads"]),
    ("random draw without seed", edit("mu = 1.0", "mu = {uniform = [0, 1]}"), ["'mu'", "seed"]),
    ("random draw misspelt", edit("mu = 1.0", "mu = {uniform = [0, 1], sed = 3}"), ["'sed'", "seed"]),
    ("unknown symbol in R", edit('R = "-mu*v"', 'R = "-mu*v - gamma*u"'),
     ["unknown symbol 'gamma'", "[perturbation.params]"]),
    ("python in R", edit('R = "-mu*v"', "R = \"__import__('os')\""), ["__import__", "not allowed"]),
    ("R(0,0) != 0", edit('R = "-mu*v"', 'R = "1 - mu*v"'), ["R(0,0) = 1", "not zero"]),
    ("R not a string", edit('R = "-mu*v"', "R = 3"), ["R must be a string"]),
    ("missing R", edit('R = "-mu*v"\n', ""), ["missing key 'R' in [perturbation]"]),
    ("missing eps", edit("eps = 0.3\n", ""), ["missing key 'eps' in [perturbation]"]),
    ("missing velocity", edit("velocity = 1.0\n", ""), ["missing key 'velocity' in [excitation]"]),
    ("missing contacts", edit("contacts = [16, 120]\n", ""), ["missing key 'contacts' in [output]"]),
    ("missing output table", GOOD.split("[output]")[0], ["missing table [output]"]),
    ("params not a table", edit("[perturbation.params]\nmu = 1.0\n", 'params = "mu=1"\n'), ["params", "table"]),
    ("bad name", edit('name = "damping-eps0.3"', "name = 7"), ["name", "string"]),
    ("not utf-8", None, ["UTF-8"]),
]


@pytest.mark.parametrize("label, text, needles", BAD, ids=[case[0] for case in BAD])
def test_bad_scene(tmp_path, label, text, needles):
    if text is None:
        path = tmp_path / "scene.toml"
        path.write_bytes(GOOD.replace("damping", "d\xe9mping").encode("latin-1"))
    else:
        path = write_scene(tmp_path, text)
    with pytest.raises(SceneError) as info:
        load_scene(str(path))
    message = str(info.value)
    assert "\n" not in message, message
    assert "scene.toml" in message or "damping-eps0.3" in message, message
    for needle in needles:
        assert needle in message, (needle, message)


def test_catalogue_is_large():
    assert len(BAD) >= 20


def test_missing_file_suggests_builtin(tmp_path):
    with pytest.raises(SceneError, match=r"not found \(did you mean the built-in scene 'fig6-eps0.1'\?\)"):
        load_scene(str(tmp_path / "fig6-eps01.toml"))
    with pytest.raises(SceneError, match="fig8-eps0.3"):
        load_scene("fig8-eps03")
    with pytest.raises(SceneError, match="'nothing-here.toml' not found"):
        load_scene("nothing-here.toml")


def test_directory(tmp_path):
    with pytest.raises(SceneError, match="is a directory"):
        load_scene(str(tmp_path))
    (tmp_path / "dir.toml").mkdir()
    with pytest.raises(SceneError, match="is a directory"):
        load_scene(str(tmp_path / "dir.toml"))


def test_parse_scene_rejects_non_tables():
    with pytest.raises(SceneError, match="table"):
        parse_scene(["not", "a", "table"], "x.toml")  # type: ignore[arg-type]
    with pytest.raises(SceneError, match="unknown builtin|unknown built-in scene 'nope'"):
        builtin_scene_path("nope")


def test_scene_is_never_executed(tmp_path):
    marker = tmp_path / "X"
    for R in (
        f"__import__('os').system('touch {marker}')",
        f"exec(\"open('{marker}', 'w')\")",
        "(lambda: 0)()",
    ):
        text = edit('R = "-mu*v"', f"R = {json.dumps(R)}")
        with pytest.raises(SceneError) as info:
            load_scene(str(write_scene(tmp_path, text)))
        assert "\n" not in str(info.value)
    assert not marker.exists()


@pytest.mark.process
def test_import_is_light():
    code = "import sys, pulsemap.solvers.data.scene; print('sympy' in sys.modules, 'scipy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]


def test_scene_is_frozen():
    scene = load_scene("fig6-eps0.1")
    with pytest.raises(Exception):
        scene.beads = 3  # type: ignore[misc]
    assert isinstance(scene, Scene)
