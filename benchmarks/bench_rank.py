"""Benchmark: what ranking every model adds to a run (``pulsemap run --rank``, asked for; not by default).

Run: python benchmarks/bench_rank.py
Prints, measured in this run (best of several after a warm-up, in this process): the seconds of
``pulsemap run default`` without and with ``--rank`` and their ratio, and the whole command's wall
time in fresh processes (interpreter start and imports included) with the load average beside it.
"""

from __future__ import annotations

import contextlib
import io
import os
import subprocess
import sys
import time

from pulsemap.solvers.cli.main import main as cli


def best(argv: list[str], repeat: int = 5) -> float:
    with contextlib.redirect_stdout(io.StringIO()):
        cli(argv)
        times = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            cli(argv)
            times.append(time.perf_counter() - t0)
    return min(times)


def process(argv: list[str], repeat: int = 3) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "pulsemap.solvers.cli.main", *argv], check=True, capture_output=True)
        times.append(time.perf_counter() - t0)
    return min(times)


def run() -> None:
    plain, ranked = ["run", "default", "--quiet"], ["run", "default", "--quiet", "--rank"]
    a, b = best(plain), best(ranked)
    print(f"pulsemap run default, warm, in one process: {a:.3f} s; with --rank {b:.3f} s (ranking x{b / a:.1f})")
    pa, pb = process(plain), process(ranked)
    print(f"  as commands (fresh processes, best of 3): {pa:.2f} s; with --rank {pb:.2f} s "
          f"(load average {os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    run()
