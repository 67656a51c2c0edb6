"""Scene tables [contact] and [masses]: parsed like [perturbation], combined with it or alone, round-tripped,
overridden with --set, and every bad input refused in one line that names the fix."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from pulsemap.solvers.data.scene import SceneError, parse_scene
from pulsemap.solvers.data.scene.overrides import with_sets


def data(contact=None, masses=None, beads=None, methods=("dns",)):
    d = {"name": "c", "excitation": {"velocity": 1.0}, "output": {"contacts": [16, 60], "methods": list(methods)}}
    if beads is not None:
        d["chain"] = {"beads": beads}
    if contact is not None:
        d["contact"] = contact
    if masses is not None:
        d["masses"] = masses
    return d


def test_a_contact_law_and_masses_parse_alone_and_round_trip():
    scene = parse_scene(data({"P": "gamma*d^(1/2)*w", "eps": 0.05, "params": {"gamma": 2.0}},
                             {"m": "1 + taper*(i - 16)", "params": {"taper": 0.01}}), "t")
    assert scene.perturbation.is_zero
    (mono,) = scene.contact.monomials
    assert (mono.a, mono.b) == (sympy_half(), 1)
    exps, coef = scene.contact.table(70)
    assert np.all(coef[0, :15] == 0.0) and np.allclose(coef[0, 15:], 0.05 * 2.0)
    m = scene.masses.bead_masses(70)
    assert np.all(m[:16] == 1.0) and np.isclose(m[20], 1.0 + 0.01 * 5)
    again = parse_scene(json.loads(json.dumps(scene.as_dict())), "t")
    assert again.contact.text == scene.contact.text and np.array_equal(again.masses.bead_masses(70), m)


def sympy_half():
    import sympy

    return sympy.Rational(1, 2)


def test_set_reaches_the_new_keys():
    scene = parse_scene(data({"P": "gamma*w", "eps": 0.05, "params": {"gamma": 1.0}}), "t")
    changed = with_sets(scene, ["contact.eps=0.02", "contact.params.gamma=3", "masses.m=1.5"])
    assert changed.contact.eps == 0.02 and changed.contact.table(30)[1][0, 20] == pytest.approx(0.06)
    assert changed.masses.bead_masses(20)[18] == 1.5


@pytest.mark.parametrize("contact, masses, beads, fix", [
    ({"P": "u*w", "eps": 0.1}, None, None, "u, v, i belong in R"),
    ({"P": "gamma", "eps": 0.1, "params": {"gamma": 1.0}}, None, None, "zero overlap"),
    ({"P": "w/d", "eps": 0.1}, None, None, "negative power of d"),
    ({"P": "w^(1/2)", "eps": 0.1}, None, None, "powers of w must be"),
    ({"P": "d*w^(-1)", "eps": 0.1}, None, None, "powers of w must be"),
    ({"P": "gamma*w", "eps": 0.1, "params": {"gamma": [1.0, 2.0]}}, None, 80, "per-contact values"),
    ({"P": "gamma*w", "eps": 0.1, "params": {"gamma": 1.0, "typo": 2.0}}, None, None, "not used in P"),
    ({"P": "w", "eps": -0.1}, None, None, "must be >= 0"),
    (None, {"m": -1.0}, None, "masses are positive"),
    (None, {"m": "1 - 0.1*(i - 16)"}, 80, "bead 26 is 0"),
    (None, {"m": [1.0, 1.1]}, None, "one mass per bead"),
    (None, {"m": "inf"}, None, "finite value"),
], ids=["P uses u", "force at rest", "negative power of d", "root of w", "negative power of w", "list length",
        "unused parameter", "negative eps", "negative mass", "mass turns negative", "short mass list", "inf mass"])
def test_bad_contact_and_mass_tables_are_refused_naming_the_fix(contact, masses, beads, fix):
    with pytest.raises(SceneError, match=fix) as info:
        parse_scene(data(contact, masses, beads), "t")
    assert "\n" not in str(info.value)


def test_a_momentum_balance_with_a_contact_term_is_refused():
    with pytest.raises(SceneError, match="momentum changes only through R"):
        parse_scene(data({"P": "w", "eps": 0.1}, methods=("dns", "momentum-law")), "t")


@pytest.mark.process
def test_the_command_line_refuses_with_exit_2_and_writes_nothing(tmp_path):
    scene = tmp_path / "bad.toml"
    scene.write_text('[excitation]\nvelocity = 1.0\n[contact]\nP = "gamma*w^(1/2)"\neps = 0.1\n'
                     '[contact.params]\ngamma = 1.0\n[output]\ncontacts = [16, 40]\nmethods = ["dns"]\n')
    out = tmp_path / "out.json"
    proc = subprocess.run([sys.executable, "-m", "pulsemap.solvers.cli.main", "run", str(scene), "--json", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2
    line = next(ln for ln in proc.stderr.splitlines() if ln.startswith("pulsemap: error:"))
    assert "powers of w" in line and not out.exists()
