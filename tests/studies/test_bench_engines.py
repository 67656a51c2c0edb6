"""pulsemap bench's engines (studies/bench/engines.py): the compiled engine, the scipy engine and the
careful user's script (studies/bench/reference_script.py) on one work-precision plot, warm and cold, with ratios."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from conftest import scene_toml
from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.data.scene import load_scene
from pulsemap.solvers.studies.bench import peak_error
from pulsemap.solvers.studies.scene_chain import make_force
from pulsemap.solvers.studies.extent import dns_span, on_contacts
from pulsemap.solvers.studies.bench.reference_script import script_peaks

pytestmark = pytest.mark.bench  # runs and times the benchmark harness (CI: -m bench)

KINDS = {"compiled", "dns", "script"}


@pytest.fixture(scope="module")
def tiny_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("engines") / "tiny.toml"
    path.write_text(scene_toml("tiny"))
    return path


@pytest.fixture(scope="module")
def cli_report(tiny_path, tmp_path_factory):
    """`pulsemap bench` on the tiny scene, quick ladder, cold runs included: (JSON, stdout, plot path)."""
    out = tmp_path_factory.mktemp("engines-out")
    proc = subprocess.run([sys.executable, "-m", "pulsemap.solvers.cli.main", "bench", str(tiny_path), "--quick",
                           "--no-baselines", "--no-models", "--repeats", "1", "--quiet", "--json",
                           str(out / "b.json"), "--plot", str(out / "b.png")], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return json.loads((out / "b.json").read_text())["scenes"][0], proc.stdout, out / "b.png"


def test_json_holds_the_three_lines_warm_and_cold(cli_report):
    report, _, _ = cli_report
    lines = {}
    for p in report["points"]:
        lines.setdefault(p["kind"], []).append(p)
    assert KINDS <= set(lines)
    for kind in KINDS:
        assert len(lines[kind]) >= 2 and all(p["time_s"] > 0 and p["missing"] == 0 for p in lines[kind])
    assert {p["line"] for p in lines["compiled"]} == {"window RK45", "window DOP853"}
    assert not any(p["note"] for p in lines["compiled"])
    assert set(report["cold"]) == KINDS
    for kind, c in report["cold"].items():
        warm = next(p for p in lines[kind] if p["line"] == c["line"] and p["setting"] == c["setting"])
        # the cold run is the same computation as the warm one: the same peaks, only the clock differs
        assert c["error"] == warm["error"] and c["missing"] == 0 and c["error"] <= report["target"]
        assert c["first_call_s"] > 0 and c["process_cpu_s"] >= 0.99 * c["first_call_cpu_s"]
    assert report["cold"]["compiled"]["engine"] == "compiled" and report["cold"]["dns"]["engine"] == "scipy"


def test_ratios_are_the_costs_at_equal_accuracy(cli_report):
    report, text, _ = cli_report
    e = report["ratios"]["engines"]
    costs = report["cost_at_target"]
    compiled = [c["time_s"] for key, c in costs.items() if key.startswith("compiled|") and c["time_s"]]
    assert e["compiled"]["time_s"] == min(compiled) and len(compiled) >= 1  # the best compiled line
    assert e["compiled_vs_script"] == pytest.approx(e["script"]["time_s"] / e["compiled"]["time_s"])
    assert e["compiled_vs_scipy"] == pytest.approx(e["scipy"]["time_s"] / e["compiled"]["time_s"])
    cold = report["cold"]
    assert e["cold"]["compiled_vs_script"] == pytest.approx(cold["script"]["first_call_s"] / cold["compiled"]["first_call_s"])
    assert e["cold"]["compiled_vs_scipy_cpu"] == pytest.approx(
        cold["dns"]["first_call_cpu_s"] / cold["compiled"]["first_call_cpu_s"])
    assert "RATIO script / compiled" in text and "RATIO cold script / compiled" in text


def test_plot_is_written(cli_report):
    pytest.importorskip("matplotlib")
    _, _, png = cli_report
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 5000


def test_without_matplotlib_the_text_and_json_still_come(tiny_path, tmp_path):
    code = ("import sys; sys.modules['matplotlib'] = None; from pulsemap.solvers.cli.main import main; "
            f"sys.exit(main(['bench', {str(tiny_path)!r}, '--quick', '--no-baselines', '--no-models', '--no-cold', "
            f"'--repeats', '1', '--quiet', '--json', {str(tmp_path / 'b.json')!r}]))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    report = json.loads((tmp_path / "b.json").read_text())["scenes"][0]
    assert KINDS <= {p["kind"] for p in report["points"]} and "RATIO script / compiled" in proc.stdout


@pytest.mark.parametrize("name", ["tiny", "vdp-mu3-v2.3"])
def test_script_peaks_agree_with_the_dns_within_its_tolerance(name, tiny_path):
    """The user's script (vectorised RHS, peaks off its dense output) against the scipy engine's full
    chain at rtol 1e-12 (peaks tracked step by step): an independent code path. Its error falls with
    its tolerance and stays within 1e3 rtol (the peak refinement is exact on the dense output; the
    rest is the integrator's global error)."""
    scene = load_scene(str(tiny_path) if name == "tiny" else name)
    beads, span = dns_span(scene)
    force = make_force(scene, beads)
    ref = simulate(Chain(beads, scene.exponent, scene.velocity, force), span,
                   integrator=Integrator(method="DOP853", rtol=1e-12, atol=1e-14, engine="scipy"))
    contacts = list(ref.contacts)
    ref_peaks = on_contacts(contacts, ref.contacts, ref.peaks, ref.alive)
    t_end = float(np.nanmax(ref.peak_times[ref.alive])) + 2.0
    errors = []
    for rtol in (1e-6, 1e-9):
        res = script_peaks(beads, scene.exponent, scene.velocity, span, force, rtol, t_end, 0.05)
        err, missing = peak_error(on_contacts(contacts, res.contacts, res.peaks, np.isfinite(res.peaks)), ref_peaks)
        assert missing == 0 and err is not None and math.isfinite(err)
        assert err <= 1e3 * rtol, (rtol, err)
        errors.append(err)
    assert errors[1] < errors[0]
