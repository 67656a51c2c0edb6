"""Work a command does ahead: the kernel a DNS will run (asked without integrating), the kernels built in a
child process, the models derived into the cache, and table rows computed in forked processes."""

from __future__ import annotations

import sys
import time

import numpy as np
import pytest

from pulsemap.solvers.chain import compiled_aot
from pulsemap.solvers.chain.dns import Chain, Integrator, compiled_kernel_of, simulate
from pulsemap.solvers.data.scene import load_scene, with_overrides
from pulsemap.solvers.studies.scene_chain import make_force
from pulsemap.solvers.studies.extent import dns_span

SHORT = (15, 24)

CASES = {  # name: (scene overrides, Integrator keywords)
    "dense table, RK45": ({}, {}),
    "general table": ({"R": "-mu*v^3"}, {}),
    "DOP853": ({}, {"method": "DOP853"}),
    "stiff: Rodas4": ({"params": {"mu": 10000.0}}, {}),
    "scipy requested": ({}, {"engine": "scipy"}),
    "LSODA: scipy": ({}, {"method": "LSODA"}),
    "generated numba force": ({"R": "-mu*sin(u)"}, {}),
    "bare chain": ({"eps": 0.0}, {}),
}


@pytest.mark.parametrize("case", list(CASES))
def test_the_kernel_asked_ahead_is_the_one_the_run_takes(case):
    overrides, integrator = CASES[case]
    scene = with_overrides(load_scene("fig8-eps0.1"), **overrides)
    beads, _ = dns_span(scene)
    force = None if scene.perturbation.eps == 0 else make_force(scene, beads)
    chain = Chain(beads, scene.exponent, scene.velocity, force)
    ahead = compiled_kernel_of(chain, integrator=Integrator(**integrator), window="auto")
    res = simulate(chain, SHORT, integrator=Integrator(**integrator), window="auto")
    if res.engine != "compiled" or "generated numba function" in res.engine_reason:
        assert ahead is None
    else:
        form = "dense" if "dense form" in res.engine_reason else "table"
        assert ahead == (res.method, form)


def test_kernels_on_disk_are_not_built_again():
    scene = load_scene("fig8-eps0.1")
    beads, _ = dns_span(scene)
    simulate(Chain(beads, scene.exponent, scene.velocity, make_force(scene, beads)), SHORT, window="auto")
    assert compiled_aot.to_build([("RK45", "dense")]) == []
    assert compiled_aot.build_in_background([("RK45", "dense"), ("RK45", "dense")]) is None
    assert compiled_aot.to_build([("Euler", "dense"), ("RK45", "sparse")]) == []  # no such kernel: nothing


@pytest.mark.process
def test_a_kernel_built_in_a_child_process_is_loaded_not_built(tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(compiled_aot, "_loaded", {})  # a process that has loaded none yet
    name = compiled_aot.module_name("RK45", "dense")
    monkeypatch.setitem(sys.modules, name, sys.modules.get(name))  # loading from tmp_path replaces it: back after
    assert compiled_aot.to_build([("RK45", "dense")]) == [("RK45", "dense")]
    child = compiled_aot.build_in_background([("RK45", "dense")])
    assert child is not None and child.wait() == 0
    assert list((tmp_path / "aot").glob("pulsemap_rk45_dense_*")) and compiled_aot.to_build([("RK45", "dense")]) == []
    run, seconds, built = compiled_aot.load("RK45", "dense")
    assert callable(run) and built == 0.0 and not list(tmp_path.glob("aot/*.failed"))


def test_a_run_that_builds_its_kernel_reports_the_build_apart_from_the_load(tmp_path, monkeypatch, capsys):
    """A DNS whose ahead-of-time kernel this machine lacks builds it in the run: ``dns_build`` in the timings is
    the build's time, the seconds the note after the build gives, and ``dns_compile`` keeps only the rest; a
    later process loads the module and reports no build."""
    from pulsemap.solvers.studies.run import run_scene

    monkeypatch.setattr(compiled_aot, "folder", lambda: tmp_path / "aot")
    monkeypatch.setattr(compiled_aot, "_loaded", {})
    name = compiled_aot.module_name("RK45", "dense")
    monkeypatch.setitem(sys.modules, name, sys.modules.get(name))  # loading from tmp_path replaces it: back after
    scene = load_scene("fig8-eps0.1")
    first = run_scene(scene, methods=["dns"])["timings_s"]
    noted = [line for line in capsys.readouterr().err.splitlines() if "compiled the chain kernels" in line]
    assert len(noted) == 1 and noted[0].endswith(f" in {first['dns_build']:.1f} s")
    assert first["dns_build"] > first["dns_compile"] >= 0.0
    monkeypatch.setattr(compiled_aot, "_loaded", {})  # a new process
    again = run_scene(scene, methods=["dns"])["timings_s"]
    assert "dns_build" not in again and "compiled the chain kernels" not in capsys.readouterr().err


def test_derive_models_fills_the_cache_and_runs_nothing(tmp_path, monkeypatch):
    from pulsemap.solvers.studies.run import derive_models

    monkeypatch.setenv("PULSEMAP_CACHE_DIR", str(tmp_path))
    scene = with_overrides(load_scene("fig8-eps0.1"), R="-mu*v - 0.37*mu*v^3")  # a map no test derived before
    derive_models(scene, ["map"], "exact", "corrected")
    assert list((tmp_path / "generated").glob("*.py"))
    assert not (tmp_path / "numba" / "aot").exists()  # no DNS: no kernel asked for


FRESH_TABLES = """
import json, threading
from pulsemap.solvers.studies.table import table
assert threading.active_count() == 1  # a fresh interpreter: the rows are forked
names = ["fig6-eps1", "fig7-eps1", "fig8-eps1"]
timing = {"dns_s", "time_s", "total_s"}
print(json.dumps([[{k: v for k, v in r.items() if k not in timing} for r in table(names, workers=w)] for w in (1, 2)]))
"""


@pytest.mark.process
def test_rows_from_forked_workers_equal_rows_computed_here():
    import json
    import subprocess

    out = subprocess.run([sys.executable, "-c", FRESH_TABLES], capture_output=True, text=True, check=True).stdout
    here, forked = json.loads(out)
    assert here == forked and len(forked) == 3
    assert np.isfinite([r["winner"]["rms_pct"] for r in forked]).all()


def test_no_calibration_ahead_for_a_shipped_monomial():
    from pulsemap.solvers.studies.dressed import _calibration_ahead

    assert _calibration_ahead(0, 1, 1.5) is None  # -mu*v: derived and calibrated coefficients ship


FRESH_MONOMIAL = """
import json, sys, threading
from pulsemap.solvers.models.dressed_expansion import is_derived
from pulsemap.solvers.studies import dressed
assert threading.active_count() == 1 and not is_derived(2, 0, 1.5)  # u^2 ships neither derived nor calibrated
ahead, jobs = dressed._calibration_ahead, []
dressed._calibration_ahead = (lambda a, b, n: None) if sys.argv[1] == "in-turn" else (
    lambda a, b, n: jobs.append(ahead(a, b, n)) or jobs[-1])
print(json.dumps({"coefficients": dressed.monomial_coefficients(2, 0, 1.5), "forked": any(jobs)}))
"""


@pytest.mark.slow
def test_a_calibration_forked_ahead_gives_the_coefficients_computed_in_turn(tmp_path):
    import json
    import os
    import subprocess

    got = {}
    for how in ("forked", "in-turn"):
        env = {**os.environ, "PULSEMAP_CACHE_DIR": str(tmp_path / how)}
        out = subprocess.run([sys.executable, "-c", FRESH_MONOMIAL, how], capture_output=True, text=True, check=True,
                             env=env).stdout
        got[how] = json.loads(out)
    assert got["forked"]["forked"] and not got["in-turn"]["forked"]
    assert got["forked"]["coefficients"] == got["in-turn"]["coefficients"]
    assert got["forked"]["coefficients"]["next"] is not None


@pytest.mark.parametrize("workers", [0, -1, 1.5, "2", True])
def test_a_bad_worker_count_is_refused_before_any_work(workers):
    from pulsemap.solvers.studies.table import TableError, table

    with pytest.raises(TableError, match="workers must be a whole number >= 1"):
        table(["fig6-eps1"], workers=workers)


@pytest.mark.process
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="workers are forked on Linux only")
def test_a_fresh_interpreter_forks_and_no_fork_while_another_thread_runs():
    import subprocess
    import threading

    from pulsemap.solvers.studies.workers import fork_pool

    code = "from pulsemap.solvers.studies.workers import fork_pool; print(fork_pool(1).submit(sum, [1, 2]).result())"
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout == "3\n"
    stop = threading.Event()
    other = threading.Thread(target=stop.wait)
    other.start()
    try:
        assert fork_pool(2) is None
    finally:
        stop.set()
        other.join()


def test_models_are_derived_while_a_missing_kernel_builds(tmp_path, monkeypatch):
    from pulsemap.solvers.studies.run import derive_while_kernels_build

    monkeypatch.setenv("PULSEMAP_CACHE_DIR", str(tmp_path))
    asked, waited, said = [], [], []

    class Child:
        def wait(self):
            waited.append(True)
            time.sleep(0.05)  # the build: the run reports the time it waited for it
            return 0

    monkeypatch.setattr(compiled_aot, "build_in_background", lambda kernels: asked.append(list(kernels)) or Child())
    scene = with_overrides(load_scene("fig8-eps0.1"), R="-mu*v - 0.41*mu*v^3")  # v^3: the general table
    timings: dict = {}
    assert derive_while_kernels_build([(scene, ["dns", "map"], "exact", "corrected")], say=said.append,
                                      timings=timings)
    assert asked == [[("RK45", "table")]] and waited == [True] and said
    assert timings["dns_build"] >= 0.05
    assert list((tmp_path / "generated").glob("map_*.py"))  # the map's module, derived meanwhile


def test_nothing_is_derived_ahead_when_no_kernel_is_missing(tmp_path, monkeypatch):
    from pulsemap.solvers.studies.run import derive_while_kernels_build

    monkeypatch.setenv("PULSEMAP_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(compiled_aot, "build_in_background", lambda kernels: None)
    scene = with_overrides(load_scene("fig8-eps0.1"), R="-mu*v - 0.43*mu*v^3")
    timings: dict = {}
    assert not derive_while_kernels_build([(scene, ["dns", "map"], "exact", "corrected")], timings=timings)
    assert not list((tmp_path / "generated").glob("map_*.py")) and "dns_build" not in timings


def test_no_child_process_means_the_run_builds_its_own(monkeypatch):
    import subprocess

    def refuse(*args, **kwargs):
        raise OSError("no more processes")

    monkeypatch.setattr(compiled_aot, "_loaded", {})
    monkeypatch.setattr(compiled_aot, "to_build", lambda kernels: list(kernels))
    monkeypatch.setattr(subprocess, "Popen", refuse)
    assert compiled_aot.build_in_background([("RK45", "dense")]) is None
