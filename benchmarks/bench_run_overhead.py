"""What a run costs around its DNS, measured in one run (docs/dns.rst, "A run around its DNS").

Run: PULSEMAP_CACHE_DIR=... python benchmarks/bench_run_overhead.py [--repeats K] [--processes P]
     [--script-rtol R]

On vdp-mu3-v2.3 and fig8-eps0.1 (paper Eq. 1 with R = -(u - mu (1 - u^2) v) and R = -mu v):

1. in-process, warm: ``pulsemap.run(scene, methods=("dns",))`` against the DNS integration it contains
   (``Result.timings["dns"]``, the same calls), best of K and the median of the per-call ratios;
2. whole processes, warm: ``pulsemap run SCENE --methods dns`` against the careful user's scipy script
   as its own process (solvers/studies/bench/reference_script.py written out with numpy and scipy only:
   vectorised full-chain DOP853, grid peaks refined by brentq on the dense output) at the loosest rtol
   of 1e-6, 1e-7, 1e-8 whose peaks are within 1e-6 of the DNS's; best of P, wall and CPU time (both
   with their bytecode cached, as installed packages have it: PYTHONPYCACHEPREFIX, a temporary folder)
   (the CPU time is what to read on a shared machine), with the share of imports, which of
   numba/scipy/sympy the process loaded (none: the ahead-of-time kernel, chain/compiled_aot.py) and
   where its CPU time goes (cProfile, one run);
3. cold vs warm: the CLI process with every cache a new machine lacks empty (first_use.new_machine_env:
   scene records, generated modules, the kernels and numba's cache, whatever NUMBA_CACHE_DIR says)
   against the warm one.
"""

from __future__ import annotations

import argparse
import inspect
import json
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pulsemap
from pulsemap.solvers.chain.peaks import velocity_scale
from pulsemap.solvers.studies.bench.lines import script_span
from pulsemap.solvers.studies.bench.measure import peak_error
from pulsemap.solvers.studies.extent import dns_span
from pulsemap.solvers.studies.bench import reference_script

from first_use import new_machine_env

SCENES = ("vdp-mu3-v2.3", "fig8-eps0.1")
SCRIPT_RTOLS = (1e-6, 1e-7, 1e-8)
TARGET = 1e-6
PULSEMAP = str(Path(sys.executable).with_name("pulsemap"))


def in_process(name: str, repeats: int, overrides: dict | None = None, warmup: int = 3) -> dict:
    """The warm in-process ``pulsemap.run(scene, methods=("dns",))`` over its DNS: best times and ratios over
    ``repeats`` runs after ``warmup`` (``overrides``: the scene's, e.g. ``{"dns.rtol": 1e-6}``)."""
    scene = pulsemap.scene(name, **(overrides or {}))
    for _ in range(warmup):
        pulsemap.run(scene, methods=("dns",))
    totals, dns = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        r = pulsemap.run(scene, methods=("dns",))
        totals.append(time.perf_counter() - t0)
        dns.append(r.timings["dns"])
    ratios = [t / d for t, d in zip(totals, dns)]
    return {"run_s": min(totals), "dns_s": min(dns), "best_ratio": min(totals) / min(dns),
            "median_ratio": statistics.median(ratios)}


def script_text(scene, rtol: float, t_end: float, dt: float) -> str:
    """The careful user's script for ``scene`` as a file of its own: numpy and scipy, no pulsemap."""
    beads, span = dns_span(scene)
    pert = scene.perturbation
    params = "".join(f"        {k} = {float(v)!r}\n" for k, v in pert.params.items())
    # the module's own definitions, so the standalone script cannot drift from it
    helpers = "\n\n".join(inspect.getsource(obj) for obj in (velocity_scale, reference_script.ScriptResult))
    body = inspect.getsource(reference_script.script_peaks)
    return f'''import time
import numpy as np
from dataclasses import dataclass


{helpers}

class Force:
    eps_i = np.where(np.arange(1, {beads} + 1) >= {scene.first_perturbed}, {float(pert.eps)!r}, 0.0)

    def force(self, u, v):
{params}        return self.eps_i * ({pert.text.replace("^", "**")})


{body}

res = script_peaks({beads}, {scene.exponent!r}, {scene.velocity!r}, {span!r}, Force(), {rtol!r}, {t_end!r}, {dt!r})
print([None if p != p else float(p) for p in res.peaks])
'''


def pick_script(name: str, folder: Path, rtol: float | None) -> tuple[Path, float, float]:
    """The script file at the loosest rtol reaching TARGET against the DNS (rtol 1e-10), its rtol and error."""
    scene = pulsemap.scene(name)
    ref = pulsemap.run(scene, methods=("dns",))
    t_end, contact_time = script_span(scene)
    for r in ([rtol] if rtol else SCRIPT_RTOLS):
        path = folder / f"script_{name}_{r:g}.py"
        path.write_text(script_text(scene, r, t_end, reference_script.GRID_STEP * contact_time))
        out = subprocess.run([sys.executable, str(path)], capture_output=True, text=True, check=True).stdout
        beads, (first, last) = dns_span(scene)
        peaks = dict(zip(range(first, last + 1), json.loads(out.replace("None", "null"))))
        got = [peaks.get(c) for c in ref.contacts]
        err, missing = peak_error(got, list(ref.peaks["dns"]))
        if rtol or (err is not None and err <= TARGET and missing == 0):
            return path, r, err
    return path, r, err


def process(cmd: list[str], env: dict) -> tuple[float, float]:
    """(wall, CPU of the child) of one process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def best_process(cmd: list[str], env: dict, repeats: int) -> tuple[float, float]:
    runs = [process(cmd, env) for _ in range(repeats)]
    return min(w for w, _ in runs), min(c for _, c in runs)


def import_shares(cmd: list[str], env: dict) -> dict:
    """Seconds of -X importtime per top-level package of a CLI process (numba, scipy, sympy, numpy, pulsemap)."""
    err = subprocess.run([sys.executable, "-X", "importtime", "-m", "pulsemap.solvers.cli.main", *cmd[1:]], env=env,
                         capture_output=True, text=True, check=True).stderr
    share: dict[str, float] = {}
    for line in err.splitlines():
        m = re.match(r"import time:\s+(\d+) \|\s+\d+ \|( *)(\S+)", line)
        if m:
            top = m.group(3).split(".")[0]
            share[top] = share.get(top, 0.0) + int(m.group(1)) * 1e-6
    return {k: round(share.get(k, 0.0), 3) for k in ("numba", "scipy", "llvmlite", "sympy", "mpmath", "numpy", "pulsemap")}


PROFILE = """import cProfile, json, pstats, sys, time
t0 = time.perf_counter()
from pulsemap.solvers.cli.main import main
imports = time.perf_counter() - t0
sys.argv = ["pulsemap"] + sys.argv[1:]
p = cProfile.Profile()
p.enable()
try:
    main()
except SystemExit:
    pass
p.disable()
stats = pstats.Stats(p).stats
cum = lambda name: max([v[3] for k, v in stats.items() if k[2] == name] or [0.0])
print(json.dumps({"import cli": imports, "main": cum("main"), "kernel load": cum("kernel_for"),
                  "integration": cum("drive"), "run_dns": cum("run_dns")}), file=sys.stderr)
"""


def profile_shares(cmd: list[str], env: dict) -> dict:
    """Seconds of one CLI process: importing the CLI, then under cProfile its ``main``, of which the
    kernel's load (compiled.kernel_for), the integration (compiled.drive) and the whole DNS step
    (run_dns); profiling inflates each a little."""
    err = subprocess.run([sys.executable, "-c", PROFILE, *cmd[1:]], env=env, capture_output=True, text=True,
                         check=True).stderr
    return {k: round(v, 3) for k, v in json.loads(err.strip().splitlines()[-1]).items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=30)
    ap.add_argument("--processes", type=int, default=5)
    ap.add_argument("--script-rtol", type=float, default=None)
    args = ap.parse_args()
    # children cache their bytecode (outside the source tree) as an installed package has it compiled
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env.setdefault("PYTHONPYCACHEPREFIX", str(Path(tempfile.gettempdir()) / "pulsemap-bench-pycache"))
    print(f"pulsemap {pulsemap.__version__}, cache {env.get('PULSEMAP_CACHE_DIR', '(default)')}")
    print("\n1. in-process, warm: pulsemap.run(scene, methods=('dns',)) over its DNS (target <= 1.25)")
    for name in SCENES:
        r = in_process(name, args.repeats)
        print(f"  {name:14s} run {r['run_s'] * 1e3:8.3f} ms  dns {r['dns_s'] * 1e3:8.3f} ms  "
              f"ratio best {r['best_ratio']:.3f}  median {r['median_ratio']:.3f}")
    print("\n2. whole processes, warm: careful script over `pulsemap run SCENE --methods dns` (target >= 2)")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for name in SCENES:
            cli = [PULSEMAP, "run", name, "--methods", "dns", "--quiet"]
            process(cli, env)  # warm: the scene's record, generated module and kernels in the caches
            script, rtol, err = pick_script(name, folder, args.script_rtol)
            cw, cc = best_process(cli, env, args.processes)
            sw, sc = best_process([sys.executable, str(script)], env, args.processes)
            print(f"  {name:14s} script (rtol {rtol:g}, max error {err:.2g}) wall {sw:6.3f} s cpu {sc:6.3f} s | "
                  f"pulsemap wall {cw:6.3f} s cpu {cc:6.3f} s | ratio wall {sw / cw:5.2f} cpu {sc / cc:5.2f}")
            print(f"  {'':14s} import seconds in the pulsemap process: {import_shares(cli, env)}")
            imported = subprocess.run(
                [sys.executable, "-c", "import sys, runpy; sys.argv = ['pulsemap'] + sys.argv[1:]; "
                 "from pulsemap.solvers.cli.main import main\ntry:\n    main()\nexcept SystemExit:\n    pass\n"
                 "print(sorted(m for m in ('numba', 'sympy', 'scipy', 'scipy.integrate', 'scipy.linalg') if m in sys.modules), "
                 "file=sys.stderr)", *cli[1:]], env=env, capture_output=True, text=True).stderr.strip().splitlines()[-1]
            print(f"  {'':14s} loaded in the pulsemap process: {imported}")
            print(f"  {'':14s} where the process's time goes: {profile_shares(cli, env)}")
        print("\n3. cold (empty pulsemap cache) vs warm CLI process")
        for name in SCENES:
            cli = [PULSEMAP, "run", name, "--methods", "dns", "--quiet"]
            cold_env = new_machine_env(Path(tmp) / f"cold-{name}", env)
            kw, kc = process(cli, cold_env)
            ww, wc = best_process(cli, cold_env, args.processes)
            print(f"  {name:14s} cold wall {kw:6.3f} s cpu {kc:6.3f} s | warm wall {ww:6.3f} s cpu {wc:6.3f} s | "
                  f"cold/warm cpu {kc / wc:5.2f}")


if __name__ == "__main__":
    main()
