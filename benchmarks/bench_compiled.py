"""The DNS ratios of the compiled engine (solvers/chain/compiled.py), measured in one run.

Run: PULSEMAP_CACHE_DIR=... python benchmarks/bench_compiled.py [--quick] [--skip-process]
     [--only accuracy,scaling,million,process]

Paper Eq. 1, x_i'' = (x_{i-1} - x_i)_+^n - (x_i - x_{i+1})_+^n + F_i(x_i, x_i'), on the scenes
vdp-mu3-v2.3 and fig8-eps0.1 (contacts first_perturbed - 1 .. 120). Reference: the scipy engine,
full chain, DOP853 at rtol 1e-12 (its distance to rtol 1e-11 printed). Error: max relative peak
error over the reference's live contacts (studies.bench.peak_error); the cost of a line at 1e-6
is interpolated log-log between the runs that bracket it (studies.bench.cost_at). Printed:

1. compiled (window, warm, best of K; its two kernels, RK45 = Dormand-Prince 5(4) and DOP853, each
   a line) vs a careful user's script (solvers/studies/bench/reference_script.py,
   also run by `pulsemap bench`): vectorised numpy RHS on the full chain, solve_ivp(DOP853,
   t_eval=grid of 0.05, dense_output=True), peaks as the first grid maximum of delta_k refined by
   brentq on delta_k' of the dense output, at equal 1e-6 max relative peak error (a warm-up, then one
   timed run per tolerance, as `pulsemap bench` times it);
2. compiled vs today's scipy window engine (window="auto", Hairer's DOP853), at the same rtol and
   at equal 1e-6 error;
3. time(contacts 4000) / time(contacts 1000), compiled window, vdp;
4. beads = 1_000_000 vs 140, 120 contacts: the simulate call (time, tracemalloc peak) and a whole
   `pulsemap run --methods dns` process (wall time, max RSS);
5. whole-process `pulsemap run vdp-mu3-v2.3 --methods dns`: cold (empty numba cache: JIT) and warm,
   wall and CPU time (the CPU time is what to read on a shared machine).
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np
from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.data.scene import load_scene
from pulsemap.solvers.studies.bench import Point, cost_at, peak_error
from pulsemap.solvers.studies.extent import dns_span, on_contacts
from pulsemap.solvers.studies.bench.reference_script import script_peaks
from pulsemap.solvers.studies.scene_chain import make_force

TARGET = 1e-6
SCENES = ("vdp-mu3-v2.3", "fig8-eps0.1")
LADDER = (1e-5, 3e-6, 1e-6, 3e-7, 1e-7, 3e-8, 1e-8, 1e-9)


def live(res, ref) -> list:
    return on_contacts(ref.contacts, res.contacts, res.peaks, res.alive)


def best_time(run, repeats: int, cpu: bool = False):
    """Warm-up, then the fastest of ``repeats`` calls: (result, wall seconds) or, with ``cpu``,
    (result, wall seconds, CPU seconds of the process, all threads)."""
    result = run()
    best, best_cpu = math.inf, math.inf
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        result = run()
        best, best_cpu = min(best, time.perf_counter() - t0), min(best_cpu, time.process_time() - c0)
    return (result, best, best_cpu) if cpu else (result, best)


# ----------------------------------------------------------------------------- sections


def equal_accuracy(name: str, quick: bool, repeats: int) -> None:
    scene = load_scene(name)
    beads, span = dns_span(scene)
    force = make_force(scene, beads)
    args = (Chain(beads, scene.exponent, scene.velocity, force), span)
    t0 = time.perf_counter()
    ref = simulate(*args, integrator=Integrator(engine="scipy", method="DOP853", rtol=1e-12, atol=1e-14))
    ref_s = time.perf_counter() - t0
    check = simulate(*args, integrator=Integrator(engine="scipy", method="DOP853", rtol=1e-11, atol=1e-13))
    conv, _ = peak_error(live(check, ref), live(ref, ref))
    print(f"\n== {name}: N={beads}, contacts {span[0]}..{span[1]}, reference scipy DOP853 full rtol 1e-12 "
          f"({ref.alive.sum()} live, {ref.stop_reason}; {ref_s:.1f} s); vs rtol 1e-11: {conv:.1e}", flush=True)
    ladder = LADDER[::2] if quick else LADDER
    lines: dict[str, list[Point]] = {"compiled window": [], "compiled DOP853": [], "scipy window": [], "script": []}
    same_rtol = {}
    for rtol in ladder:
        for label, kw in (("compiled window", dict()),
                          ("compiled DOP853", dict(method="DOP853")),
                          ("scipy window", dict(engine="scipy"))):
            res, sec = best_time(lambda: simulate(*args, window="auto",
                                                  integrator=Integrator(rtol=rtol, atol=rtol * 1e-2, **kw)),
                                 repeats if label.startswith("compiled") else max(1, repeats // 10))
            err, missing = peak_error(live(res, ref), live(ref, ref))
            lines[label].append(Point("dns", label, f"rtol {rtol:g}", rtol, err, missing, sec, int(res.nfev)))
            same_rtol.setdefault(rtol, {})[label] = sec
            print(f"  {label:16s} rtol {rtol:7.1e} err {err:9.2e} missing {missing:2d} nfev {res.nfev:7d} "
                  f"time {sec * 1e3:9.2f} ms  [{res.engine}/{res.method}, {res.window_beads} beads]", flush=True)
    t_end = float(np.nanmax(ref.peak_times)) + 2.0
    for rtol in ((1e-7, 1e-8) if quick else (1e-6, 1e-7, 1e-8, 1e-9)):
        res, sec = best_time(lambda: script_peaks(beads, scene.exponent, scene.velocity, span, force, rtol, t_end,
                                                  dt=0.05), 1)
        peaks = res.peaks
        err, missing = peak_error([None if not np.isfinite(p) else float(p) for p in peaks], live(ref, ref))
        lines["script"].append(Point("baseline", "script", f"rtol {rtol:g}", rtol, err, missing, sec))
        print(f"  {'script DOP853':16s} rtol {rtol:7.1e} err {err:9.2e} missing {missing:2d} "
              f"time {sec * 1e3:9.2f} ms (after a warm-up)", flush=True)
    cost = {k: cost_at(v, TARGET) for k, v in lines.items()}
    for k, (c, how) in cost.items():
        print(f"  -> {k:16s} at {TARGET:g}: {'n/a' if c is None else f'{c * 1e3:.2f} ms'} ({how})")
    for kernel in ("compiled window", "compiled DOP853"):
        comp = cost[kernel][0]
        for k in ("script", "scipy window"):
            if comp and cost[k][0]:
                print(f"  RATIO {k} / {kernel} at equal {TARGET:g} error: {cost[k][0] / comp:8.1f}x")
    for rtol in (1e-6, 1e-8):
        if rtol in same_rtol:
            r = same_rtol[rtol]
            print(f"  RATIO scipy window / compiled at the same rtol {rtol:g}: "
                  f"{r['scipy window'] / r['compiled window']:8.1f}x")


def scaling(repeats: int) -> None:
    scene = load_scene("vdp-mu3-v2.3")
    times = {}
    for last in (1000, 4000):
        beads = last + 11
        force = make_force(scene, beads)
        res, sec = best_time(lambda: simulate(Chain(beads, scene.exponent, scene.velocity, force), (15, last),
                                              integrator=Integrator(rtol=1e-8, atol=1e-10), window="auto"), max(1, repeats // 4))
        times[last] = sec
        print(f"  vdp contacts 15..{last}: {sec * 1e3:.1f} ms, {res.stop_reason}, window {res.window_beads} beads")
    print(f"  RATIO time(4000 contacts) / time(1000): {times[4000] / times[1000]:.2f}")


def million(repeats: int) -> None:
    scene = load_scene("vdp-mu3-v2.3")
    force = make_force(scene, 140)  # uniform R: the table does not depend on N
    out = {}
    for beads in (140, 1_000_000):
        run = lambda: simulate(Chain(beads, scene.exponent, scene.velocity, force), (15, 120),
                               integrator=Integrator(rtol=1e-8, atol=1e-10), window="auto")
        res, sec = best_time(run, repeats)
        tracemalloc.start()
        run()
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        out[beads] = (sec, peak)
        print(f"  simulate beads={beads:>9d}: {sec * 1e3:7.2f} ms, tracemalloc peak {peak / 1e3:8.1f} kB, "
              f"window {res.window_beads} beads")
    print(f"  RATIO beads 1e6 / 140 (simulate call): time {out[1_000_000][0] / out[140][0]:.2f}x, "
          f"memory {out[1_000_000][1] / out[140][1]:.2f}x")


def process(args: list[str], env: dict) -> tuple[float, float, float]:
    """Wall time (s), max RSS (MB) and CPU time (user + system, s) of one child process (the CPU
    time is the one to read on a shared machine: the wall time includes waiting for a core)."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(args, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    sec = time.perf_counter() - t0
    if status != 0:
        raise RuntimeError(f"{' '.join(args)} failed: {proc.stderr.read().decode()[-500:]}")
    return sec, usage.ru_maxrss / 1024.0, usage.ru_utime + usage.ru_stime


def whole_process() -> None:
    exe = str(Path(sys.executable).with_name("pulsemap"))
    with tempfile.TemporaryDirectory(prefix="bench-compiled-") as tmp:
        env = {**os.environ, "NUMBA_CACHE_DIR": str(Path(tmp) / "numba")}
        cold = process([exe, "run", "vdp-mu3-v2.3", "--methods", "dns", "--quiet"], env)
        warm = min(process([exe, "run", "vdp-mu3-v2.3", "--methods", "dns", "--quiet"], env) for _ in range(3))
        print(f"  pulsemap run vdp-mu3-v2.3 --methods dns: cold (JIT) {cold[0]:.2f} s wall, {cold[2]:.2f} s CPU; "
              f"warm {warm[0]:.2f} s wall, {warm[2]:.2f} s CPU (max RSS {warm[1]:.0f} MB)")
        res = {}
        for beads in (140, 1_000_000):
            path = Path(tmp) / f"vdp-{beads}.toml"
            path.write_text(vdp_scene_text(beads), encoding="utf-8")
            res[beads] = process([exe, "run", str(path), "--methods", "dns", "--quiet"], env)
            print(f"  pulsemap run (beads = {beads}, 120 contacts, dns): {res[beads][0]:.2f} s wall, "
                  f"{res[beads][2]:.2f} s CPU, max RSS {res[beads][1]:.0f} MB")
        print(f"  RATIO beads 1e6 / 140 (whole process): CPU time {res[1_000_000][2] / res[140][2]:.2f}x, "
              f"max RSS {res[1_000_000][1] / res[140][1]:.2f}x")


def vdp_scene_text(beads: int) -> str:
    return "\n".join([
        'name = "vdp-beads"', "[chain]", f"beads = {beads}", "exponent = 1.5", "first_perturbed = 16",
        "[excitation]", "velocity = 2.3", "[perturbation]", 'R = "-(u - mu*(1 - u^2)*v)"', "eps = 0.1",
        "[perturbation.params]", "mu = 3.0", "[output]", "contacts = [16, 120]", 'methods = ["dns"]', ""])


SECTIONS = ("accuracy", "scaling", "million", "process")


def main(argv: list[str]) -> None:
    quick = "--quick" in argv
    repeats = 5 if quick else 20
    only = argv[argv.index("--only") + 1].split(",") if "--only" in argv else list(SECTIONS)
    if "--skip-process" in argv:
        only = [s for s in only if s != "process"]
    print("bench_compiled: compiled engine (numba DOPRI5, moving window) vs scipy; best of "
          f"{repeats} warm runs per compiled point; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores",
          flush=True)
    simulate(Chain(40, 1.5, 1.0), (1, 20), window="auto")  # load the JIT cache before any timing
    if "accuracy" in only:
        for name in SCENES:
            equal_accuracy(name, quick, repeats)
    if "scaling" in only:
        print("\n== scaling with contacts")
        scaling(repeats)
    if "million" in only:
        print("\n== beads = 1_000_000 vs 140")
        million(repeats)
    if "process" in only:
        print("\n== whole process")
        whole_process()


if __name__ == "__main__":
    main(sys.argv[1:])
