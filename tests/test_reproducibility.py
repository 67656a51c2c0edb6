"""Reproducibility: every output says what produced it, and the same input gives the
same numbers bit for bit -- in the same process, and in a fresh process with an empty cache.

Compared: the whole JSON output (run, derive, profile) after one json round trip (floats are
written with repr, which round-trips exactly). Excluded: wall-clock timings only -- the keys
``timings_s`` (run, derive) and ``timing_s`` (profile) -- because they measure the machine, not
the result. Nothing else is excluded: a difference anywhere else fails the test.

One caveat is recorded rather than excluded: ``pulsemap derive`` tries a closed-form law within
``--sympy-seconds`` of wall-clock time, so with several powers of B its law kind ("implicit" or
"quadrature") can depend on the machine's load; the JSON records ``sympy_seconds``, and
``--sympy-seconds 0`` (used here) makes it deterministic.
"""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib  # type: ignore[no-redef]

from pulsemap.solvers.cli.main import main
from pulsemap.solvers.data.scene import with_overrides

ROOT = Path(__file__).resolve().parent.parent
TIMING_KEYS = frozenset({"timings_s", "timing_s"})

SCENE = """\
name = "repro"
[chain]
beads = 40
first_perturbed = 6
[excitation]
velocity = 1.0
[perturbation]
R = "-k*u"
eps = 0.2
[perturbation.params]
k = {uniform = [0, 1], seed = SEED}
[output]
contacts = [6, 30]
methods = ["map", "dns"]
"""


def without_timings(data):
    """The JSON data with every wall-clock timing removed (recursively)."""
    if isinstance(data, dict):
        return {k: without_timings(v) for k, v in data.items() if k not in TIMING_KEYS}
    if isinstance(data, list):
        return [without_timings(v) for v in data]
    return data


def round_trip(data) -> dict:
    return json.loads(json.dumps(data))


def fresh_process(argv: list[str], tmp_path: Path) -> dict:
    """``pulsemap ARGV --json OUT`` in a new interpreter with its own, empty cache; the JSON."""
    out = tmp_path / f"out-{len(list(tmp_path.iterdir()))}.json"
    cache = tmp_path / f"cache-{out.stem}"
    env = {**os.environ, "PULSEMAP_CACHE_DIR": str(cache),
           "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.run([sys.executable, "-m", "pulsemap.solvers.cli.main", *argv, "--json", str(out)],
                          capture_output=True, text=True, cwd=tmp_path, env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert cache.is_dir()  # it really used (and filled) its own cache, not ours
    return json.loads(out.read_text())


def in_process(argv: list[str], tmp_path: Path, capsys) -> dict:
    out = tmp_path / f"out-{len(list(tmp_path.iterdir()))}.json"
    assert main([*argv, "--json", str(out)]) == 0
    capsys.readouterr()
    return json.loads(out.read_text())


@pytest.fixture
def scene_file(tmp_path) -> Path:
    path = tmp_path / "repro.toml"
    path.write_text(SCENE.replace("SEED", "3"), encoding="utf-8")
    return path


# --------------------------------------------------------------------------- what is recorded


def test_the_version_has_one_source(capsys):
    import pulsemap.symbolic
    import pulsemap.solvers

    with open(ROOT / "pyproject.toml", "rb") as fh:
        declared = tomllib.load(fh)["project"]["version"]
    assert pulsemap.symbolic.__version__ == pulsemap.solvers.__version__ == declared
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0 and capsys.readouterr().out.strip() == f"pulsemap {declared}"


def test_run_output_records_what_produced_it(scene_file):
    from pulsemap.solvers.studies.run import run_scene
    from pulsemap.solvers.data.scene import load_scene, parse_scene

    scene = load_scene(str(scene_file))
    data = round_trip(run_scene(scene))
    prov = data["provenance"]
    assert prov["pulsemap"] == data["pulsemap_version"] == importlib.import_module("pulsemap").__version__
    assert all(prov[name] for name in ("python", "numpy", "scipy", "sympy", "mpmath"))
    # the scene as resolved: complete enough to rebuild the very same scene, seed included
    assert parse_scene(data["scene"], data["scene"]["source"]) == scene
    assert data["scene"]["perturbation"]["params"]["k"] == {"uniform": [0.0, 1.0], "seed": 3}
    assert data["scene"]["dns"] == {"rtol": 1e-10, "atol": 1e-12, "method": "auto"}
    assert data["scene"]["chain"] == {"beads": 40, "exponent": 1.5, "first_perturbed": 6}
    # the choices and tolerances actually used
    assert data["choices"]["profile"] == data["map"]["profile"] == "exact"
    assert data["choices"]["variant"] == data["map"]["variant"] == "paper"
    assert (data["dns"]["rtol"], data["dns"]["atol"]) == (1e-10, 1e-12)
    assert data["dns"]["mode"].startswith("window") and data["dns"]["window_behind"] >= 2  # [dns] mode default
    assert data["dns"]["method"] in ("DOP853", "RK45", "Radau", "BDF", "LSODA")
    assert data["seed"]["contact"] == 5 and data["seed"]["from"] == "DNS peak at contact 5"


@pytest.mark.process
def test_provenance_reads_the_installed_versions_without_importing_the_libraries():
    """The versions recorded are importlib.metadata's, read in a process that loads neither sympy nor scipy."""
    code = ("import json, sys; from pulsemap.symbolic.provenance import provenance; p = provenance(); "
            "print(json.dumps([p, sorted(m for m in ('sympy', 'scipy', 'importlib.metadata') if m in sys.modules)]))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    versions, loaded = json.loads(out)
    from importlib import metadata

    assert {name: versions[name] for name in ("numpy", "scipy", "sympy", "mpmath")} == \
           {name: metadata.version(name) for name in ("numpy", "scipy", "sympy", "mpmath")}
    assert loaded == []


def test_derive_and_profile_outputs_record_what_produced_them():
    from pulsemap.symbolic.balance import derive_balance
    from pulsemap.symbolic.derivation import derive_all, to_json
    from pulsemap.symbolic.perturbation import make_perturbation
    from pulsemap.symbolic.provenance import provenance
    from pulsemap.symbolic.report import profile_report

    d = round_trip(to_json(derive_all(make_perturbation("-mu*v", 0.1, {"mu": 2.0}), sympy_seconds=0)))
    assert d["provenance"] == provenance()
    assert (d["n"], d["profile"], d["variant"], d["dps"], d["sympy_seconds"]) == (1.5, "exact", "paper", 16, 0)
    assert d["params"] == {"mu": 2.0} and d["eps"] == 0.1
    for model in ("energy", "momentum"):
        b = round_trip(to_json(derive_balance(make_perturbation("-mu*v", 0.1, {"mu": 2.0}), model, sympy_seconds=0)))
        assert b["provenance"] == provenance() and b["model"] == model
        assert (b["params"], b["eps"], b["n"], b["profile"], b["dps"]) == ({"mu": 2.0}, 0.1, 1.5, "exact", 16)
    p = round_trip(profile_report(n=1.5, profile="pade"))
    assert p["provenance"] == provenance()
    assert (p["n"], p["profile"], p["dps"]) == (1.5, "pade", 30)


# --------------------------------------------------------------------------- bit for bit


@pytest.mark.process
def test_same_scene_and_seed_give_the_same_numbers_bit_for_bit(scene_file, tmp_path, capsys):
    """Two runs in this process and one in a fresh process with an empty cache."""
    argv = ["run", str(scene_file), "--quiet"]
    first = in_process(argv, tmp_path, capsys)
    second = in_process(argv, tmp_path, capsys)
    third = fresh_process(argv, tmp_path)
    assert first["timings_s"] and first["timings_s"] != second["timings_s"]  # what is excluded does vary
    assert without_timings(first) == without_timings(second) == without_timings(third)
    # and the comparison had something to compare
    assert sum(p is not None for p in first["peaks"]["dns"]) > 20
    assert sum(p is not None for p in first["peaks"]["map"]) > 20


@pytest.mark.process
def test_derive_json_is_reproducible_across_processes(tmp_path, capsys):
    argv = ["derive", "-(u - mu*(1-u^2)*v)", "--param", "mu=3", "--fold", "mu", "--A0", "0.5",
            "--sympy-seconds", "0"]
    first = in_process(argv, tmp_path, capsys)
    second = in_process(argv, tmp_path, capsys)
    third = fresh_process(argv, tmp_path)
    assert without_timings(first) == without_timings(second) == without_timings(third)
    assert first["longwave"]["kind"] == "quadrature" and len(first["stationary"]["roots"]) == 2


@pytest.mark.process
def test_profile_json_is_reproducible_across_processes(tmp_path, capsys):
    argv = ["profile", "--n", "1.5"]
    first = in_process(argv, tmp_path, capsys)
    third = fresh_process(argv, tmp_path)
    assert without_timings(first) == without_timings(third)
    assert first["S0"] > 1 and "timing_s" in first


# --------------------------------------------------------------------------- seeds


def test_a_different_seed_gives_different_draws(scene_file):
    from pulsemap.solvers.studies.run import run_scene
    from pulsemap.solvers.data.scene import load_scene

    scenes = {seed: with_overrides(load_scene(str(scene_file)), params={"k": {"uniform": [0, 1], "seed": seed}})
              for seed in (3, 4)}
    draws = {seed: sc.perturbation.bead_values("k", 40) for seed, sc in scenes.items()}
    # the contract: numpy's default_rng(seed).uniform(low, high, N), bead k at index k - 1
    np.testing.assert_array_equal(draws[3], np.random.default_rng(3).uniform(0.0, 1.0, 40))
    np.testing.assert_array_equal(draws[3], load_scene(str(scene_file)).perturbation.bead_values("k", 40))
    assert np.all(draws[3] != draws[4])
    peaks = {seed: run_scene(sc, methods=["map"], seed_peak=0.75)["peaks"]["map"] for seed, sc in scenes.items()}
    assert peaks[3][0] != peaks[4][0] and peaks[3] != peaks[4]
    assert peaks[3] == run_scene(scenes[3], methods=["map"], seed_peak=0.75)["peaks"]["map"]
