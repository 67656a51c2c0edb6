"""Benchmark: the command-line paths outside the DNS kernel, cold (empty caches) and warm, each a fresh process.

Run: python benchmarks/bench_cold_paths.py [--repeat N] [--only NAME ...]
Prints, measured in this run, the CPU time (user + system of the process and its children, best of N)
and the wall time (best of N; the targets are judged on it: the time a user waits, which a cold table or
dressed law shortens by working on two cores) of:

* ``derive-warm``: ``pulsemap derive "-mu*v" --param mu=1`` with its derivation cached (target <= 0.5 s);
  beside it the same with only the integrals and sympy's outcomes cached (the printed derivation removed)
  and a bare ``import sympy, numpy``;
* ``table-cold``: ``pulsemap table`` (all built-in scenes) with an empty PULSEMAP_CACHE_DIR and an empty
  NUMBA_CACHE_DIR (target <= 10 s); beside it the same with numba's kernels compiled beforehand;
* ``dressed-cold``: the dressed law of a monomial not shipped, ``pulsemap derive "-mu*u^2" --param mu=1
  --model dressed``, empty caches (target <= 10 s); beside it with numba's kernels compiled beforehand;
* ``derive8``: ``pulsemap derive "(u+v+1)^8-1"`` from an empty cache and warm.
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

EXE = str(Path(sys.executable).with_name("pulsemap"))


def measure(argv: list[str], env: dict, prepare=None, repeat: int = 3) -> tuple[float, float]:
    """(best CPU s, best wall s) of ``argv`` in fresh processes; ``prepare()`` runs before each (untimed)."""
    cpus, walls = [], []
    for _ in range(repeat):
        if prepare is not None:
            prepare()
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run(argv, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        walls.append(time.perf_counter() - t0)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpus.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return min(cpus), min(walls)


def emptied(*folders: Path):
    """A prepare step: remove the folders (the caches start empty)."""
    return lambda: [shutil.rmtree(f, ignore_errors=True) for f in folders]


def row(name: str, cpu_wall: tuple[float, float], target: float | None = None) -> None:
    cpu, wall = cpu_wall  # a target is the time a user waits (wall); cold paths use both cores, so CPU can exceed it
    goal = f"target <= {target:g} s wall: {'met' if wall <= target else 'NOT met'} ({wall / target:.2f}x)" if target else ""
    print(f"  {name:58s} CPU {cpu:7.2f} s   wall {wall:7.2f} s   {goal}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="fresh processes per figure (best taken; default 3)")
    ap.add_argument("--only", nargs="*", default=None, choices=("derive-warm", "table-cold", "dressed-cold", "derive8"))
    args = ap.parse_args()
    wanted = set(args.only or ("derive-warm", "table-cold", "dressed-cold", "derive8"))
    rep = args.repeat
    with tempfile.TemporaryDirectory(prefix="bench-cold-paths-") as name:
        tmp = Path(name)
        pm, nb = tmp / "pm", tmp / "numba"
        env = {**os.environ, "PULSEMAP_CACHE_DIR": str(pm), "NUMBA_CACHE_DIR": str(nb)}
        print(f"pulsemap cold and warm paths, {rep} fresh process(es) each, best CPU time (process + children)")
        if "derive-warm" in wanted:
            print("derive, warm:")
            argv = [EXE, "derive", "-mu*v", "--param", "mu=1"]
            subprocess.run(argv, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            row("pulsemap derive -mu*v (derivation cached)", measure(argv, env, repeat=rep), 0.5)
            row("  the same, only integrals and sympy's outcomes cached", measure(argv, env, emptied(pm / "derivation"), rep))
            row("  python -c 'import sympy, numpy'", measure([sys.executable, "-c", "import sympy, numpy"], env, repeat=rep))
        if "table-cold" in wanted:
            print("table, cold:")
            argv = [EXE, "table", "--fresh", "--rows", str(tmp / "rows.jsonl"), "--quiet"]
            row("pulsemap table (empty pulsemap and numba caches)", measure(argv, env, emptied(pm, nb), rep), 10)
            row("  the same, numba's kernels compiled beforehand", measure(argv, env, emptied(pm), rep))
        if "dressed-cold" in wanted:
            print("dressed law of a new monomial, cold:")
            argv = [EXE, "derive", "-mu*u^2", "--param", "mu=1", "--model", "dressed"]
            row("pulsemap derive -mu*u^2 --model dressed (empty caches)", measure(argv, env, emptied(pm, nb), rep), 10)
            row("  the same, numba's kernels compiled beforehand", measure(argv, env, emptied(pm), rep))
        if "derive8" in wanted:
            print("derive (u+v+1)^8-1:")
            argv = [EXE, "derive", "(u+v+1)^8-1", "--quiet"]
            row("cold (empty cache)", measure(argv, env, emptied(pm), rep))
            row("warm (derivation cached)", measure(argv, env, repeat=rep))
            row("  warm, only integrals and sympy's outcomes cached", measure(argv, env, emptied(pm / "derivation"), rep))


if __name__ == "__main__":
    main()
