"""R = 0: the first sanity check a user tries. Every method runs; the laws stay constant, the DNS
keeps the soliton, the maps do what their variant does at eps = 0 (erratum 5, docs/errata.rst)."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import write_scene
from pulsemap.solvers.cli.main import main
from pulsemap.solvers.data.scene import load_scene
from pulsemap.solvers.studies.methods import MODELS
from pulsemap.solvers.studies.run import run_scene

SCENE = """name = "r0"
[chain]
first_perturbed = 16
[excitation]
velocity = 1.0
[perturbation]
R = "0"
eps = 0.1
[output]
contacts = [16, 40]
methods = ["dns", "map", "longwave", "energy-map", "energy-law", "momentum-map", "momentum-law", "relaxed", "dressed-law"]
"""


@pytest.fixture(scope="module")
def r0_scene(tmp_path_factory):
    return load_scene(str(write_scene(tmp_path_factory.mktemp("r0"), SCENE)))


@pytest.fixture(scope="module")
def r0_run(r0_scene):
    return run_scene(r0_scene)


def test_every_method_runs_without_a_perturbation(r0_run):
    for name in ("dns",) + MODELS:
        assert r0_run["peaks"][name] is not None, name
        assert all(v is not None and np.isfinite(v) for v in r0_run["peaks"][name]), name


def test_the_dns_keeps_the_soliton(r0_run):
    dns = np.array(r0_run["peaks"]["dns"])
    assert np.ptp(dns) < 1e-4 * dns.mean()  # the wave is formed by contact 16 (it settles by ~1e-5)


def test_laws_and_balance_maps_stay_at_the_seed(r0_run):
    seed = r0_run["seed"]["peak"]
    for name in ("longwave", "energy-map", "energy-law", "momentum-map", "momentum-law", "dressed-law"):
        assert r0_run["peaks"][name] == pytest.approx([seed] * len(r0_run["contacts"]), rel=1e-12), name
    assert r0_run["longwave"]["kind"] == "constant"
    assert r0_run["errors"]["longwave"]["max_pct"] < 1e-2


def test_the_relaxed_map_is_the_identity_at_r0(r0_run):
    """Its segment runs are unperturbed solitary waves: every ratio is 1 to the DNS accuracy."""
    seed = r0_run["seed"]["peak"]
    assert r0_run["peaks"]["relaxed"] == pytest.approx([seed] * len(r0_run["contacts"]), rel=1e-6)


@pytest.mark.parametrize("variant", ["corrected", "1d"])
def test_the_corrected_maps_are_constant_at_r0(r0_scene, r0_run, variant):
    res = run_scene(r0_scene, methods=["map"], variant=variant, seed_peak=r0_run["seed"]["peak"])
    assert res["peaks"]["map"] == pytest.approx([r0_run["seed"]["peak"]] * len(res["contacts"]), rel=1e-10)


def test_the_paper_map_drifts_at_r0_as_errata_item_5_says(r0_run):
    """(1 + f7/(2 f1))^(-1/P) per contact (docs/models.rst; erratum 5, docs/errata.rst): a small steady decay."""
    peaks = np.array(r0_run["peaks"]["map"])
    ratios = peaks[1:] / peaks[:-1]
    assert np.all(ratios < 1) and np.ptp(ratios) < 1e-9
    assert r0_run["map"]["eps0_drift"] < 0


def test_cli_runs_r0_with_exit_0(r0_scene, tmp_path, capsys):
    path = write_scene(tmp_path, SCENE)
    assert main(["run", str(path), "--quiet"]) == 0
    assert "error" not in capsys.readouterr().err
