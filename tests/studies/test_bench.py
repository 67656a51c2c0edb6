"""pulsemap bench (solvers/bench.py): work-precision points, interpolation to equal accuracy, CLI."""

from __future__ import annotations

import math
import subprocess
import sys

import pytest

from conftest import scene_toml
from pulsemap.solvers.studies.bench import Ladder, Point, bench_scene, cost_at, peak_error, to_csv, to_text
from pulsemap.solvers.data.scene import load_scene

SCENE_TOML = scene_toml("tiny")


def line(errors_times, kind="dns"):
    return [Point(kind, "x", f"rtol {r:g}", r, e, 0, t) for r, (e, t) in
            zip((1e-4, 1e-6, 1e-8, 1e-10), errors_times)]


def test_cost_at_interpolates_a_power_law_exactly():
    # time = 0.01 * err^(-1/4): log-log linear, so the interpolation is exact
    pts = line([(e, 0.01 * e ** -0.25) for e in (1e-3, 1e-5, 1e-7, 1e-9)])
    t, how = cost_at(pts, 1e-6)
    assert t == pytest.approx(0.01 * 1e-6 ** -0.25, rel=1e-12) and "interpolated" in how


def test_cost_at_refuses_to_extrapolate_and_bounds_from_above():
    assert cost_at(line([(1e-2, 1.0), (1e-3, 2.0)]), 1e-6)[0] is None
    t, how = cost_at(line([(1e-8, 3.0), (1e-9, 2.0), (1e-10, 5.0)]), 1e-6)
    assert t == 2.0 and "upper bound" in how
    # a run with missing contacts does not count
    pts = [Point("dns", "x", "a", 1e-4, 1e-7, 3, 0.1), Point("dns", "x", "b", 1e-6, 1e-8, 0, 1.0)]
    assert cost_at(pts, 1e-6)[0] == 1.0


def test_peak_error_counts_missing_values():
    err, missing = peak_error([1.0, None, 2.2, 5.0], [1.0, 2.0, 2.0, None])
    assert err == pytest.approx(0.1) and missing == 1
    assert peak_error([None], [1.0]) == (None, 1)


@pytest.fixture(scope="module")
def tiny_report(tmp_path_factory):
    path = tmp_path_factory.mktemp("bench") / "tiny.toml"
    path.write_text(SCENE_TOML)
    ladder = Ladder(rtols=(1e-5, 1e-7, 1e-9), reference_rtol=1e-12, check_rtol=1e-11,
                    methods=("DOP853", "LSODA"), full_methods=("DOP853",), script=((1e-8, 0.005),), repeats=1,
                    engines=False)  # the engines' lines and cold runs: test_bench_engines.py
    return bench_scene(load_scene(str(path)), ladder)


@pytest.mark.bench
def test_reference_is_converged_and_errors_fall_with_tolerance(tiny_report):
    r = tiny_report
    assert r["reference"]["convergence"] < 1e-8 and r["reference"]["missing"] == 0
    for kind, line_name in (("dns", "window DOP853"), ("dns", "window LSODA"), ("baseline-b", "full DOP853")):
        errs = [p["error"] for p in r["points"] if p["kind"] == kind and p["line"] == line_name]
        assert len(errs) == 3 and errs[0] > errs[2] and errs[2] < 1e-6
    a = [p for p in r["points"] if p["kind"] == "baseline-a"]
    assert len(a) == 1 and 1e-9 < a[0]["error"] < 1e-2  # grid sampling limits the script's accuracy


@pytest.mark.bench
def test_every_model_run_offers_is_measured(tiny_report):
    from pulsemap.solvers.studies import run
    from pulsemap.solvers.data.scene import PROFILES, VARIANTS

    lines = {p["line"] for p in tiny_report["points"] if p["kind"] == "model"}
    models = getattr(run, "MODELS", ("map", "longwave"))
    assert {f"map/{p}/{v}" for p in PROFILES for v in VARIANTS} <= lines
    assert {f"longwave/{p}" for p in PROFILES} <= lines
    assert {m.split("/")[0] for m in lines} <= set(models)
    for p in tiny_report["points"]:
        if p["kind"] == "model":
            assert p["error"] is None and p["time_s"] > 0  # a model's error is in percent, as every output's
            assert math.isfinite(p["max_pct"]) and 0 <= p["rms_pct"] <= p["max_pct"]


@pytest.mark.bench
def test_ratios_and_reports(tiny_report):
    rat = tiny_report["ratios"]
    assert rat["dns"]["time_s"] > 0 and rat["baseline_b"]["time_s"] > 0
    assert rat["dns_vs_b"] == pytest.approx(rat["baseline_b"]["time_s"] / rat["dns"]["time_s"])
    m = rat["models"]
    # a ratio of the times measured, not a speed claim (no timing assertions: the compiled DNS can beat the map)
    assert m["map_line"] == "map/exact/paper" and m["run_dns_vs_map"] == pytest.approx(m["run_dns_time_s"] / m["map_time_s"])
    text = to_text([tiny_report])
    assert "ratio (b)/DNS" in text and "window LSODA" in text
    paper = next(p for p in tiny_report["points"] if p["line"] == "map/exact/paper")
    assert "models against the reference DNS (" in text and f"RMS {paper['rms_pct']:.3g} %" in text  # percent
    csv = to_csv([tiny_report]).splitlines()
    assert len(csv) == 1 + len(tiny_report["points"]) and csv[0].startswith("scene,kind,line")


@pytest.mark.process
@pytest.mark.parametrize("argv, pattern", [
    (["bench", "--repeats", "0"], "--repeats"),
    (["bench", "no-such-scene"], "no-such-scene"),
    (["bench", "--target", "2"], "--target"),
])
def test_cli_errors_are_one_line(argv, pattern):
    proc = subprocess.run([sys.executable, "-m", "pulsemap.solvers.cli.main", *argv], capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.startswith("pulsemap: error:") and pattern in proc.stderr
    assert "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 1


@pytest.mark.bench
def test_plot_writes_a_png(tiny_report, tmp_path):
    pytest.importorskip("matplotlib")
    from pulsemap.solvers.studies.bench import plot

    out = tmp_path / "wp.png"
    plot([tiny_report], str(out))
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out.stat().st_size > 5000


CONTACT_SCENE = {"name": "dashpot-on-taper", "excitation": {"velocity": 1.0}, "contact": {"P": "w", "eps": 0.02},
                 "masses": {"m": "1 + 0.003*(i - 16)"}, "output": {"contacts": [16, 50], "methods": ["dns"]}}


def test_the_bench_chain_carries_the_scenes_contact_term_and_masses():
    """Every DNS line of a contact or mass scene integrates the scene's own chain (the one `pulsemap run` integrates);
    an on-site scene keeps its force."""
    import numpy as np

    import pulsemap
    from pulsemap.solvers.studies.bench.lines import scripts_refusal
    from pulsemap.solvers.studies.scene_chain import scene_chain
    from pulsemap.solvers.studies.extent import dns_span

    sc = pulsemap.scene(CONTACT_SCENE)
    beads, _ = dns_span(sc)
    chain = scene_chain(sc, beads)
    assert chain.force is None and chain.masses is not None and chain.contact is not None
    np.testing.assert_array_equal(chain.masses[15:18], [1.0, 1.003, 1.006])
    assert chain.contact.coef[0, 14] == 0.0 and chain.contact.coef[0, 15] == 0.02  # contacts 15 and 16
    assert "on-site R on unit masses" in scripts_refusal(sc)
    onsite = load_scene("fig6-eps0.1")
    assert scene_chain(onsite, 60).force is not None and scripts_refusal(onsite) is None


@pytest.mark.bench
def test_bench_measures_a_contact_and_mass_scene():
    """Both engines' DNS lines converge to the reference on a damped taper, the energy law is measured against it,
    and the user's scripts (on-site R only) are left out with the reason."""
    from dataclasses import replace

    import pulsemap
    from pulsemap.solvers.studies.bench import quick_ladder

    r = bench_scene(pulsemap.scene(CONTACT_SCENE), replace(quick_ladder(), cold=False))
    assert r["reference"]["convergence"] < 1e-8 and r["live_contacts"] == 35
    for kind in ("dns", "compiled", "baseline-b"):
        pts = [p for p in r["points"] if p["kind"] == kind and p["line"].endswith("DOP853")]
        assert len(pts) == 3 and pts[0]["error"] > pts[-1]["error"] and pts[-1]["error"] < 1e-7
    assert not [p for p in r["points"] if p["kind"] in ("script", "baseline-a")]
    assert "on-site R" in r["scripts_not_measured"] and "not measured" in to_text([r])
    law = next(p for p in r["points"] if p["line"] == "energy-law/exact")
    assert 0 < law["rms_pct"] < 5
    assert not [p for p in r["points"] if p["line"].startswith("map/")]  # refused for the scene
