"""The two DNS engines and the careful user's script on one work-precision plot: the lines, the cold
runs and the ratios of ``pulsemap bench``.

Lines (warm: one warm-up, then best of K, as every other line of the benchmark):

* ``compiled``: ``simulate(..., integrator=Integrator(engine="compiled", method="RK45"), window="auto")``, the numba
  Dormand-Prince 5(4) moving-window engine, over ``ladder.compiled_rtols``;
* ``dns``: the scipy engine on the moving window (studies/bench/__init__.py's DNS lines, every method);
* ``script``: studies/bench/reference_script.py (vectorised full-chain DOP853, dense-output peaks) over
  ``ladder.script_rtols``.

Cold: for each of the three, the cheapest ladder run of its line that reaches the target is run
again as the first call of a fresh Python process whose numba cache (NUMBA_CACHE_DIR) is an
empty temporary directory, so the compiled engine pays its JIT; recorded: that call's wall and
CPU time, and the whole process's wall and CPU time (imports included).

Ratios: compiled against the script and against the best scipy-engine line, warm at equal
accuracy (``cost_at``: log-log interpolation at the target), cold at the runs above.
"""

from __future__ import annotations

import json
import os
import pickle
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable

from pulsemap.solvers.studies.bench.measure import (BenchError, Ladder, Point, best_line, best_of, fmt, peak_error,
                                                    tolerances)

__all__ = ["cold_runs", "engine_ratios", "reference_points"]

KINDS = ("compiled", "dns", "script")  # compiled engine, scipy engine, the careful user's script
#: The cold child's program (argv: SCENE.pickle JOB); not ``-m``, since the bench package imports this module.
CHILD = (f"import json, sys; from {__name__} import _first_call; "
         "print(json.dumps(_first_call(sys.argv[1], json.loads(sys.argv[2]))))")


def reference_points(scene, contacts: list[int], ref: list, ladder: Ladder,
                     log: Callable[[str], None]) -> list[Point]:
    """The careful user's script over ``ladder.script_rtols`` (warm-up, then one timed run each)."""
    from pulsemap.solvers.studies.bench.lines import script_span
    from pulsemap.solvers.studies.scene_chain import make_force
    from pulsemap.solvers.studies.extent import dns_span, on_contacts
    from pulsemap.solvers.studies.bench.reference_script import GRID_STEP, script_peaks

    beads, span = dns_span(scene)
    force = make_force(scene, beads)
    t_end, contact_time = script_span(scene)
    out = []
    for rtol in ladder.script_rtols:
        def run(rtol=rtol):
            res = script_peaks(beads, scene.exponent, scene.velocity, span, force, rtol, t_end,
                               GRID_STEP * contact_time)
            return res, res.wall_time_s

        res, best = best_of(run, 1)
        err, missing = peak_error(on_contacts(contacts, res.contacts, res.peaks, res.peaks == res.peaks), ref)
        point = Point("script", "full DOP853 vectorised", f"rtol {rtol:g}", rtol, err, missing, best, res.nfev)
        log(f"  script     {point.line:22s} {point.setting:11s} err {fmt(err)} missing {missing:3d} time {best:8.4f} s")
        out.append(point)
    return out


def _cheapest_at(points: list[dict], kind: str, target: float) -> dict | None:
    ok = [p for p in points if p["kind"] == kind and p["missing"] == 0 and p["error"] is not None
          and p["error"] <= target]
    return min(ok, key=lambda p: p["time_s"]) if ok else None


def cold_runs(scene, ref: list, points: list[dict], target: float, log: Callable[[str], None]) -> dict:
    """For each kind, its cheapest run reaching ``target`` again as the first call of a fresh process
    with an empty numba cache (module docstring); {kind: measurement} (a kind without such a run: absent)."""
    from pulsemap.solvers.studies.bench.lines import script_span

    out = {}
    t_end = None
    for kind in KINDS:
        p = _cheapest_at(points, kind, target)
        if p is None:
            log(f"  cold {kind}: no warm run reached {target:g}, not measured")
            continue
        if kind == "script" and t_end is None:
            t_end = script_span(scene)
        job = {"kind": kind, "method": p["line"].split()[-1] if kind != "script" else "DOP853", "rtol": p["rtol"],
               "t_end": None if t_end is None else t_end[0], "contact_time": None if t_end is None else t_end[1]}
        m = _child(scene, job)
        err, missing = peak_error(m.pop("peaks"), ref)
        out[kind] = {"line": p["line"], "setting": p["setting"], "rtol": p["rtol"], "error": err, "missing": missing,
                     "warm_time_s": p["time_s"], **m}
        log(f"  cold {kind:9s} {p['line']:22s} {p['setting']:11s} first call {m['first_call_s']:8.4f} s "
            f"({m['first_call_cpu_s']:.3f} s CPU), whole process {m['process_wall_s']:.2f} s "
            f"({m['process_cpu_s']:.2f} s CPU), err {fmt(err)}")
    return out


def _child(scene, job: dict) -> dict:
    """Run ``job`` in a fresh interpreter with an empty numba cache: the child's measurement."""
    with tempfile.TemporaryDirectory(prefix="pulsemap-bench-cold-") as tmp:
        path = Path(tmp) / "scene.pickle"
        path.write_bytes(pickle.dumps(scene))
        env = {**os.environ, "NUMBA_CACHE_DIR": str(Path(tmp) / "numba")}
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-c", CHILD, str(path), json.dumps(job)], env=env,
                              capture_output=True, text=True)
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise BenchError(f"cold run of {job['kind']} failed: {(proc.stderr.strip().splitlines() or ['?'])[-1]}")
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    out["process_wall_s"] = wall
    out["process_cpu_s"] = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return out


def _first_call(scene_path: str, job: dict) -> dict:
    """In the child: build the force (not timed), then time the first call of the job's line."""
    from pulsemap.solvers.chain.dns import Integrator, simulate
    from pulsemap.solvers.studies.scene_chain import scene_chain
    from pulsemap.solvers.studies.extent import dns_span, on_contacts
    from pulsemap.solvers.studies.bench.reference_script import GRID_STEP, script_peaks

    scene = pickle.loads(Path(scene_path).read_bytes())
    beads, span = dns_span(scene)
    chain = scene_chain(scene, beads)
    contacts = list(range(scene.contacts[0], scene.contacts[1] + 1))
    t0, c0 = time.perf_counter(), time.process_time()
    if job["kind"] == "script":
        res = script_peaks(beads, scene.exponent, scene.velocity, span, chain.force, job["rtol"], job["t_end"],
                           GRID_STEP * job["contact_time"])
        alive, engine = res.peaks == res.peaks, "script"
    else:
        integrator = Integrator(method=job["method"], engine="compiled" if job["kind"] == "compiled" else "scipy",
                                **tolerances(scene, job["rtol"]))
        res = simulate(chain, span, integrator=integrator, window="auto")
        alive, engine = res.alive, res.engine
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return {"first_call_s": wall, "first_call_cpu_s": cpu, "engine": engine,
            "peaks": on_contacts(contacts, res.contacts, res.peaks, alive)}


def engine_ratios(costs: dict, cold: dict) -> dict:
    """Compiled against the script and the scipy engine: warm at equal accuracy, cold (first call, JIT in)."""
    (c_t, c_line), (s_t, s_line), (d_t, d_line) = (best_line(costs, k) for k in ("compiled", "script", "dns"))
    ratio = lambda a, b: (a / b) if a and b else None  # noqa: E731
    out = {"compiled": {"time_s": c_t, "line": c_line}, "script": {"time_s": s_t, "line": s_line},
           "scipy": {"time_s": d_t, "line": d_line},
           "compiled_vs_script": ratio(s_t, c_t), "compiled_vs_scipy": ratio(d_t, c_t), "cold": {}}
    comp = cold.get("compiled")
    for kind, name in (("script", "compiled_vs_script"), ("dns", "compiled_vs_scipy")):
        other = cold.get(kind)
        if comp and other:
            out["cold"][name] = ratio(other["first_call_s"], comp["first_call_s"])
            out["cold"][name + "_cpu"] = ratio(other["first_call_cpu_s"], comp["first_call_cpu_s"])
            out["cold"][name + "_process_cpu"] = ratio(other["process_cpu_s"], comp["process_cpu_s"])
    return out
