"""A scene file's record (solvers/data/scene/record.py): read back without sympy, the same scene and run."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from conftest import scene_toml, write_scene
from pulsemap.solvers.data.scene import load_scene, parse_scene
from pulsemap.solvers.data.scene.record import CachedPerturbation
from pulsemap.solvers.studies.run import run_scene


def test_second_load_is_the_record_and_the_same_scene(tmp_path):
    path = write_scene(tmp_path, scene_toml("rec", beads=60, contacts=(16, 30)).replace("mu = 1.0", "mu = 0.7"))
    first, second = load_scene(path), load_scene(path)
    assert not isinstance(first.perturbation, CachedPerturbation)
    assert isinstance(second.perturbation, CachedPerturbation)
    assert second == first and first == second
    assert second.as_dict() == first.as_dict()
    pf, ps = first.perturbation, second.perturbation
    assert (ps.used_parameters, ps.site_dependent, ps.is_uniform, ps.is_zero, ps.is_polynomial) == \
           (pf.used_parameters, pf.site_dependent, pf.is_uniform, pf.is_zero, pf.is_polynomial)
    assert ps.R == pf.R  # parsed on demand, the same expression
    a = run_scene(first, methods=["dns", "map"])
    b = run_scene(second, methods=["dns", "map"])
    assert a["peaks"] == b["peaks"]  # bit for bit


def test_the_record_is_keyed_by_the_scene_not_the_file_text(tmp_path):
    """Comments, spacing and key order do not make a new scene; a changed value does."""
    text = scene_toml("rec6", contacts=(16, 30))
    load_scene(write_scene(tmp_path, text))
    again = load_scene(write_scene(tmp_path, "# the same scene, written otherwise\n" + text.replace(" = ", "=")))
    assert isinstance(again.perturbation, CachedPerturbation)


def test_an_overridden_scene_is_recorded_like_a_file(tmp_path):
    """--set and scene(name, **kw) rebuild the scene from its table: the second time from its record."""
    from pulsemap.solvers.data.scene.overrides import with_sets

    base = load_scene(write_scene(tmp_path, scene_toml("rec7", contacts=(16, 30))))
    first, second = (with_sets(base, ["dns.rtol=1e-5", "perturbation.params.mu=0.4"]) for _ in range(2))
    assert not isinstance(first.perturbation, CachedPerturbation)
    assert isinstance(second.perturbation, CachedPerturbation)
    assert second == first and second.as_dict() == first.as_dict()
    assert (second.dns["rtol"], second.perturbation.params["mu"]) == (1e-5, 0.4)
    other = with_sets(base, ["dns.rtol=1e-6"])  # another table: parsed, not the record of the first
    assert not isinstance(other.perturbation, CachedPerturbation) and other.dns["rtol"] == 1e-6


def test_an_edited_file_is_parsed_again(tmp_path):
    path = write_scene(tmp_path, scene_toml("rec2", contacts=(16, 30)))
    load_scene(path)
    path.write_text(path.read_text().replace("eps = 0.1", "eps = 0.2"))
    scene = load_scene(path)
    assert scene.perturbation.eps == 0.2
    assert not isinstance(scene.perturbation, CachedPerturbation)


def test_random_draw_and_list_values_read_back_alike(tmp_path):
    text = scene_toml("rec3", beads=40, contacts=(16, 30)).replace("mu = 1.0", "mu = {uniform = [0.5, 1.5], seed = 4}")
    path = write_scene(tmp_path, text)
    first, second = load_scene(path), load_scene(path)
    assert isinstance(second.perturbation, CachedPerturbation)
    assert second.perturbation.site_dependent == ("mu",)
    np.testing.assert_array_equal(second.perturbation.bead_values("mu", 40), first.perturbation.bead_values("mu", 40))


def test_expressions_of_i_are_not_recorded(tmp_path):
    path = write_scene(tmp_path, scene_toml("rec4", contacts=(16, 30)).replace("mu = 1.0", 'mu = "1 + 0.01*i"'))
    load_scene(path)
    assert not isinstance(load_scene(path).perturbation, CachedPerturbation)


def test_a_recorded_scene_and_its_force_load_no_sympy(tmp_path):
    path = write_scene(tmp_path, scene_toml("rec5", contacts=(16, 30)))
    code = ("import sys; from pulsemap.solvers.data.scene import load_scene; "
            "from pulsemap.solvers.studies.scene_chain import make_force; "
            f"s = load_scene({str(path)!r}); make_force(s, 40); print('sympy' in sys.modules)")
    env = dict(os.environ)
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env)
            for _ in range(2)]
    assert [r.stdout.strip() for r in runs] == ["True", "False"]


def test_without_a_usable_cache_the_scene_still_loads(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("PULSEMAP_CACHE_DIR", str(blocker / "cache"))
    scene = load_scene("fig8-eps0.1")
    assert scene.perturbation.eps == 0.1 and not isinstance(scene.perturbation, CachedPerturbation)


@pytest.mark.parametrize("field, forged, needle", [
    ("contacts", lambda d: d["output"].update(contacts=[16, 1e9]), "[output] contacts last must be an integer"),
    ("contacts", lambda d: d["output"].update(contacts=[16, 10**9]), "beyond the supported 1000000 beads"),
    ("beads", lambda d: d["chain"].update(beads=20), "contact 30 is beyond a chain of 20 beads"),
    ("exponent", lambda d: d["chain"].update(exponent=50.0), "outside the supported range"),
    ("eps", lambda d: d["perturbation"].update(eps=-1.0), "eps = -1.0 must be >= 0"),
    ("name", lambda d: d.update(name="x\x1b[2Jy"), "contains control characters"),
    ("R", lambda d: d["perturbation"].update(R="-mu*v\x1b[2J"), "R must be a printable formula"),
    ("params", lambda d: d["perturbation"]["params"].update(mu=[1.0, 2.0]), "2 per-bead values for a chain of 60"),
])
def test_a_forged_record_is_checked_as_the_scene_file_and_parsed_again(field, forged, needle, tmp_path, monkeypatch,
                                                                        capsys):
    """A record edited with its digest recomputed is re-validated like user input: refused with one note
    naming the problem, and the scene is the file's."""
    from pulsemap.symbolic import cache

    monkeypatch.setenv("PULSEMAP_CACHE_DIR", str(tmp_path / "cache"))
    path = write_scene(tmp_path, scene_toml("forged", beads=60, contacts=(16, 30)))
    original = load_scene(path)
    (entry_path,) = (tmp_path / "cache" / "scenes").glob("*.json")
    entry = json.loads(entry_path.read_text())
    forged(entry["value"]["scene"])
    entry["sha256"] = cache.digest(entry["value"])
    entry_path.write_text(json.dumps(entry))
    capsys.readouterr()
    scene = load_scene(path)
    err = capsys.readouterr().err
    assert scene == original and scene.contacts == (16, 30) and scene.name == "forged"
    assert err.count("\n") == 1 and "refused as a scene file would be" in err and needle in err, err
    assert "\x1b" not in err
