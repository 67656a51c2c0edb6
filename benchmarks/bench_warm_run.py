"""What a warm run costs beyond its work, as the three ratios its targets are judged by, measured side by side.

Run: PULSEMAP_CACHE_DIR=... python benchmarks/bench_warm_run.py [--scene NAME] [--rounds P] [--repeats K]

On vdp-mu3-v2.3 (paper Eq. 1 with R = -(u - mu (1 - u^2) v)) unless --scene says otherwise, every
cache warm (each command runs twice first):

1. CPU time of a warm default ``pulsemap run SCENE`` (every method of the scene) over the
   ``--methods dns`` process (target <= 1.5), and the ``--methods dns`` process's own CPU time
   (target <= 0.2 s);
2. CPU time of ``pulsemap run SCENE --methods dns --set dns.rtol=1e-5`` over the same process
   without ``--set`` (target <= 1.1);
3. in-process ``pulsemap.run(scene, methods=("dns",))`` over the DNS it contains
   (``Result.timings["dns"]``) at the loosest DNS rtol of 1e-6 .. 1e-9 whose peaks are within 1e-6
   of the rtol 1e-10 DNS (target <= 1.15), best of K and the median of the per-call ratios.

Processes run in interleaved rounds (A, B, A, B, ...; best of P each: the CPU time of a child,
user + system, is what to read on a shared machine), with their bytecode cached as an installed
package has it (PYTHONPYCACHEPREFIX, a temporary folder). Each process is also run once to list
which of sympy, scipy, numba and importlib.metadata it loaded (none, on these warm paths).
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

import pulsemap
from pulsemap.solvers.studies.bench.measure import peak_error

from bench_run_overhead import in_process  # the sibling script (its directory is on sys.path)

TARGET = 1e-6
RTOLS = (1e-6, 1e-7, 1e-8, 1e-9)
PULSEMAP = str(Path(sys.executable).with_name("pulsemap"))
LOADED = ("sympy", "scipy", "numba", "importlib.metadata")
WHAT_LOADED = ("import sys; sys.argv = ['pulsemap'] + sys.argv[1:]\n"
               "from pulsemap.solvers.cli.main import main\ntry:\n    main()\nexcept SystemExit:\n    pass\n"
               f"print(sorted(m for m in {LOADED!r} if m in sys.modules), file=sys.stderr)")


def cpu(cmd: list[str], env: dict) -> tuple[float, int]:
    """(CPU seconds, peak RSS in kB) of one child process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    if status != 0:
        raise SystemExit(f"{' '.join(cmd)} failed (status {status})")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), usage.ru_maxrss


def side_by_side(commands: dict[str, list[str]], env: dict, rounds: int) -> dict[str, tuple[float, int]]:
    """Best CPU time (and the peak RSS of that run) of each command over interleaved rounds."""
    for cmd in commands.values():  # warm: scene records, generated modules, kernels, bytecode
        cpu(cmd, env)
        cpu(cmd, env)
    runs: dict[str, list[tuple[float, int]]] = {name: [] for name in commands}
    for _ in range(rounds):
        for name, cmd in commands.items():
            runs[name].append(cpu(cmd, env))
    return {name: min(r) for name, r in runs.items()}


def loaded(cmd: list[str], env: dict) -> str:
    err = subprocess.run([sys.executable, "-c", WHAT_LOADED, *cmd[1:]], env=env, capture_output=True,
                         text=True).stderr
    return err.strip().splitlines()[-1] if err.strip() else "?"


def just_reaching(name: str) -> float:
    """The loosest DNS rtol of RTOLS whose peaks are within TARGET of the rtol 1e-10 DNS's."""
    ref = pulsemap.run(pulsemap.scene(name, **{"dns.rtol": 1e-10}), methods=("dns",))
    for rtol in RTOLS:
        got = pulsemap.run(pulsemap.scene(name, **{"dns.rtol": rtol}), methods=("dns",))
        err, missing = peak_error(list(got.peaks["dns"]), list(ref.peaks["dns"]))
        if err is not None and err <= TARGET and missing == 0:
            return rtol
    return RTOLS[-1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="vdp-mu3-v2.3")
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--repeats", type=int, default=300)
    args = ap.parse_args()
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env.setdefault("PYTHONPYCACHEPREFIX", str(Path(tempfile.gettempdir()) / "pulsemap-bench-pycache"))
    name = args.scene
    base = [PULSEMAP, "run", name, "--quiet"]
    commands = {"default": base, "dns": base + ["--methods", "dns"],
                "dns --set": base + ["--methods", "dns", "--set", "dns.rtol=1e-5"]}
    print(f"pulsemap {pulsemap.__version__}, scene {name}, cache {env.get('PULSEMAP_CACHE_DIR', '(default)')}")
    best = side_by_side(commands, env, args.rounds)
    for label, cmd in commands.items():
        t, rss = best[label]
        print(f"  {label:10s} cpu {t:6.3f} s  peak RSS {rss / 1024:6.1f} MB  loaded {loaded(cmd, env)}")
    print(f"1. default run / --methods dns process, CPU: {best['default'][0] / best['dns'][0]:.2f} (target <= 1.5); "
          f"--methods dns process {best['dns'][0]:.3f} s CPU (target <= 0.2)")
    print(f"2. --set dns.rtol=1e-5 / plain --methods dns process, CPU: {best['dns --set'][0] / best['dns'][0]:.2f} "
          "(target <= 1.1)")
    rtol = just_reaching(name)
    r = in_process(name, args.repeats, {"dns.rtol": rtol}, warmup=5)
    print(f"3. run() / its DNS at rtol {rtol:g} (peaks within {TARGET:g}): best {r['best_ratio']:.3f}, median "
          f"{r['median_ratio']:.3f} (target <= 1.15); run {r['run_s'] * 1e3:.3f} ms, DNS {r['dns_s'] * 1e3:.3f} ms")


if __name__ == "__main__":
    main()
