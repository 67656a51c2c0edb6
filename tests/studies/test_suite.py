"""pulsemap suite (solvers/suite.py): stiff and extreme scenes, guards, statuses."""

from __future__ import annotations

import json
import math

import pytest

from pulsemap.solvers.data.scene import load_scene, with_overrides
from pulsemap.solvers.studies.suite import (
    CHECK_CONTACTS,
    check_contacts,
    max_rel,
    non_finite,
    other_method,
    resolve,
    run_case,
    run_suite,
    silent_model_errors,
    suite_scenes,
    to_text,
)

REQUIRED = {"damp-10", "damp-100", "damp-1000", "stiff-foundation", "v0-1e-6", "v0-1e6", "eps1",
            "n1.1", "n2.5", "n3", "chain10000", "vdp-fold", "nonstiff", "unstable"}


def test_suite_has_every_case_of_the_issue_and_they_load():
    assert REQUIRED <= set(suite_scenes())
    mus = {}
    for name in suite_scenes():
        scene = load_scene(resolve(name))
        assert scene.name == name and "dns" in scene.methods
        mus[name] = scene
    eps_mu = {n: mus[n].perturbation.eps * float(mus[n].perturbation.params["mu"]) for n in ("damp-10", "damp-100", "damp-1000")}
    assert eps_mu == pytest.approx({"damp-10": 10.0, "damp-100": 100.0, "damp-1000": 1000.0})
    assert mus["chain10000"].beads == 10000 and {mus[n].exponent for n in ("n1.1", "n2.5", "n3")} == {1.1, 2.5, 3.0}
    assert {mus[n].velocity for n in ("v0-1e-6", "v0-1e6")} == {1e-6, 1e6}
    assert float(mus["vdp-fold"].perturbation.params["mu"]) == pytest.approx(1.47, abs=0.05)
    # the suite is not among the built-in scenes `pulsemap table` iterates
    from pulsemap.solvers.data.scene import builtin_scenes

    assert not REQUIRED & set(builtin_scenes())


def test_helpers():
    assert non_finite({"a": [1.0, float("nan")], "b": {"c": float("inf")}, "d": "x"}) == ["a[1]", "b.c"]
    assert non_finite({"a": [1.0, None]}) == []
    assert max_rel([1.0, 2.0, None], [1.0, 1.0, 3.0]) == (1.0, 1)
    assert other_method("DOP853") == "LSODA" and other_method("RK45") == "LSODA" and other_method("LSODA") == "RK45"
    assert check_contacts((16, 120)) == (16, 120) and check_contacts((16, 9990)) == (16, 15 + CHECK_CONTACTS)
    assert silent_model_errors({"map_error": 0.7, "longwave_error": 0.1, "warnings": []}) == [
        "map off the DNS by 70 % (max rel) and nothing in the run output warned"]
    assert silent_model_errors({"map_error": 0.7, "warnings": ["map: pulse died at contact 9"]}) == []
    assert silent_model_errors({"map_error": 0.2, "longwave_error": None, "warnings": []}) == []


def test_unstable_foundation_is_stopped_by_the_guard_without_nan():
    row = run_case("unstable", check=False)
    assert row["status"] == "stopped" and row["stop_reason"].startswith("blow-up")
    assert any("blow-up" in w for w in row["warnings"])
    json.dumps(row, allow_nan=False)


def test_stiff_damping_runs_the_cheaper_kernel_and_agrees_with_the_other_kind():
    """eps mu = 100: the compiled Dormand-Prince (cheaper than Rodas4 below 300x the contact rate),
    checked by the scipy engine's implicit LSODA; eps mu = 1000: Rodas4, checked by the explicit RK45."""
    row = run_case("damp-100")
    assert row["method"] == "RK45" and row["status"].startswith("ok")
    assert row["dns_error_vs"].startswith("LSODA")  # implicit, on the scipy engine
    assert row["dns_error"] is not None and row["dns_error"] < 1e-6 and row["dns_error_mismatch"] == 0
    assert any("pulse died" in w for w in row["warnings"])  # the map is told the pulse is gone
    stiffer = run_case("damp-1000")
    assert stiffer["method"] == "Rodas4" and stiffer["dns_error_vs"].startswith("RK45")  # explicit, compiled
    assert stiffer["status"].startswith("ok") and stiffer["dns_error_mismatch"] == 0


def test_a_long_scene_is_checked_over_its_first_contacts(tmp_path, monkeypatch):
    """The check run stops after CHECK_CONTACTS contacts; the error is over those, as an independent
    LSODA run over exactly those contacts gives it, and the 'vs' column says where it stops."""
    from conftest import scene_toml
    from pulsemap.solvers.studies import suite
    from pulsemap.solvers.studies.run import run_scene

    path = tmp_path / "long.toml"
    path.write_text(scene_toml("long", eps=0.01, contacts=(16, 40)))
    monkeypatch.setattr(suite, "CHECK_CONTACTS", 10)
    row = run_case(str(path))
    scene = load_scene(str(path))
    rtol = scene.dns["rtol"] / 100
    assert row["method"] == "RK45" and row["dns_error_vs"] == f"LSODA rtol {rtol:g} to 25"
    first = run_scene(scene, dns_window="auto")["peaks"]["dns"]
    check = run_scene(with_overrides(scene, dns={"rtol": rtol, "atol": scene.dns["atol"] / 100, "method": "LSODA"}),
                      methods=["dns"], dns_window="auto")["peaks"]["dns"]
    assert len(first) == 25 and row["dns_error"] == pytest.approx(max_rel(first[:10], check[:10])[0], rel=1e-6)
    assert 0 < row["dns_error"] < 1e-5


def test_large_eps_is_warned():
    row = run_case("eps1")
    assert row["status"] == "ok, warned" and any("not small" in w for w in row["warnings"])
    assert row["dns_error"] < 1e-6 and math.isfinite(row["map_error"])


def test_refused_scene_is_a_status_not_a_crash(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text('name = "bad"\n[chain]\nexponent = 1.5\nfirst_perturbed = 16\n[excitation]\nvelocity = 1.0\n'
                    '[perturbation]\nR = "1 + u"\neps = 0.1\n[output]\ncontacts = [16, 30]\nmethods = ["dns"]\n')
    row = run_case(str(path), check=False)
    assert row["status"] == "refused" and "R(0,0)" in row["message"]
    assert "refused" in to_text({"cases": [row], "stiff_ratio": {"ratio": None}})


@pytest.mark.slow
def test_whole_suite_runs_without_failure():
    report = run_suite()
    text = to_text(report)
    for row in report["cases"]:
        assert row["status"] in ("ok", "ok, warned", "stopped", "SILENT"), (row["scene"], row.get("message"))
        if row["status"] != "stopped" and row.get("live_contacts"):
            assert row["dns_error"] is not None and row["dns_error"] < 1e-5, row["scene"]
    json.dumps(report, allow_nan=False)
    assert report["stiff_ratio"]["ratio"] is not None and "stiff damping" in text


def test_unknown_names_are_refused_before_anything_runs(tmp_path):
    from pulsemap.solvers.studies.suite import SuiteError, check_names

    path = tmp_path / "mine.toml"
    path.write_text("not even toml")  # exists: loading it is run_case's business (a refused row)
    check_names(["damp-10", "fig8-eps0.1", "default", str(path)])
    with pytest.raises(SuiteError, match=r"unknown scene 'damp-1000x'.*did you mean 'damp-1000'"):
        run_suite(["damp-10", "damp-1000x"])  # refused before damp-10 runs
    with pytest.raises(SuiteError, match="unknown scene"):
        check_names([str(tmp_path / "absent.toml")])
