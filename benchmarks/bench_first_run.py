"""First call of each compiled DNS kernel: cold (empty kernel cache: the ahead-of-time build of
chain/compiled_aot.py, or numba's JIT compile for a generated force) against warm (the built module
or numba's cache loaded), each in a fresh Python process.

Run: python benchmarks/bench_first_run.py [--repeats K]

For each case, one child process with an empty NUMBA_CACHE_DIR (and an empty pulsemap cache whose
generated modules are copied in once, so no derivation is timed), then K more children with the
same, now filled, cache. Each child imports pulsemap, builds the scene's force and calls
``simulate`` once, then prints the DNSResult's ``compile_s`` (the kernel's build, compile or load:
chain/compiled.kernel_for) and ``wall_time_s`` (the integration alone). Printed per case: cold
compile_s, warm compile_s (best of K), their ratio, the integration time, the child's import time
and which kernel the warm child ran (ahead-of-time: numba never imported; JIT); then
the whole ``pulsemap run default --methods dns`` process, cold and warm (wall and CPU seconds of
the child: on a shared machine read the CPU column).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from first_use import new_machine_env

#: name: (scene, overrides, simulate keyword arguments); each exercises one kernel specialisation.
CASES = {
    "RK45, no force (bare chain)": ("fig8-eps0.1", {"perturbation.eps": 0.0}, {}),
    "RK45, dense table (-mu v)": ("fig8-eps0.1", {}, {}),
    "RK45, general table (-mu v^3)": ("fig8-eps0.1", {"perturbation.R": "-mu*v**3"}, {}),
    "RK45, generated force (-mu sin u)": ("fig8-eps0.1", {"perturbation.R": "-mu*sin(u)"}, {}),
    "DOP853, dense table": ("fig8-eps0.1", {}, {"method": "DOP853"}),
    "Rodas4, dense table (stiff)": ("fig8-eps0.1", {"perturbation.params.mu": 10000.0}, {}),
}

CHILD = r"""
import json, sys, time
t0 = time.perf_counter()
import pulsemap
from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.studies.scene_chain import make_force
from pulsemap.solvers.studies.extent import dns_span
t_import = time.perf_counter() - t0
name, overrides, kwargs = json.loads(sys.argv[1])
sc = pulsemap.scene(name, **overrides)
beads, span = dns_span(sc)
force = None if sc.perturbation.eps == 0 else make_force(sc, beads)
c0 = time.process_time()
res = simulate(Chain(beads, sc.exponent, sc.velocity, force), span, window="auto", integrator=Integrator(**kwargs))
cpu = time.process_time() - c0
print(json.dumps({"import_s": t_import, "compile_s": res.compile_s, "dns_s": res.wall_time_s, "cpu_s": cpu,
                  "method": res.method, "reason": res.engine_reason,
                  "path": "JIT" if "numba" in sys.modules else "ahead-of-time"}))
"""


def child(args: list[str], env: dict) -> tuple[str, str, float, float]:
    """Run a child process: (stdout, stderr, wall seconds, CPU seconds of the child)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    out = subprocess.run(args, env=env, capture_output=True, text=True, check=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return out.stdout, out.stderr, wall, cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3, help="warm children per case (best of)")
    opts = parser.parse_args()
    base = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "PULSEMAP_"))}
    with tempfile.TemporaryDirectory(prefix="bench-first-run-") as tmp:
        gen_cache = Path(tmp) / "pulsemap"  # generated modules: made once, shared by every child
        print("compile_s: the kernel's compile (cold) or cache load (warm), wall; CPU: the whole simulate call's "
              "CPU seconds (compile or load + integration), the column to read on a shared machine")
        print("process CPU: the whole child's, with the C compiler it ran (an ahead-of-time build)")
        print(f"{'case':36s} {'cold s':>8s} {'warm s':>8s} {'cold/warm':>9s} {'cold CPU':>8s} {'warm CPU':>8s} "
              f"{'process CPU cold':>16s} {'warm':>6s} {'dns s':>8s} {'import s':>8s}  kernel")
        for i, (label, (scene, overrides, kwargs)) in enumerate(CASES.items()):
            env = {**base, "PULSEMAP_CACHE_DIR": str(gen_cache), "NUMBA_CACHE_DIR": str(Path(tmp) / f"numba{i}")}
            arg = json.dumps([scene, overrides, kwargs])
            runs = []
            for _ in range(1 + opts.repeats):
                out, err, _, process_cpu = child([sys.executable, "-c", CHILD, arg], env)
                runs.append(({**json.loads(out.strip().splitlines()[-1]), "process_cpu_s": process_cpu}, err))
            (cold, cold_err), warm = runs[0], [r for r, _ in runs[1:]]
            w = min(r["compile_s"] for r in warm)
            noted = "compiling the chain kernels" in cold_err and not any("compiling" in e for _, e in runs[1:])
            print(f"{label:36s} {cold['compile_s']:8.2f} {w:8.3f} {cold['compile_s'] / w:9.0f} "
                  f"{cold['cpu_s']:8.2f} {min(r['cpu_s'] for r in warm):8.3f} "
                  f"{cold['process_cpu_s']:16.2f} {min(r['process_cpu_s'] for r in warm):6.2f} "
                  f"{min(r['dns_s'] for r in warm):8.4f} {min(r['import_s'] for r in warm):8.2f}  "
                  f"{cold['method']} {warm[0]['path']}{'' if noted else '  (compile note missing or repeated!)'}",
                  flush=True)

        exe = Path(sys.executable).with_name("pulsemap")
        env = new_machine_env(Path(tmp) / "whole")
        times = [child([str(exe), "run", "default", "--methods", "dns"], env)[2:] for _ in range(1 + opts.repeats)]
        print(f"\n`pulsemap run default --methods dns`, whole process, empty caches then warm (best of {opts.repeats}):")
        print(f"  cold: wall {times[0][0]:.2f} s, CPU {times[0][1]:.2f} s; warm: wall "
              f"{min(t[0] for t in times[1:]):.2f} s, CPU {min(t[1] for t in times[1:]):.2f} s; "
              f"cold/warm CPU {times[0][1] / min(t[1] for t in times[1:]):.1f}x")


if __name__ == "__main__":
    main()
