"""Sweep throughput: 2 worker processes against the serial sweep, measured in one run.

Run: PYTHONPATH=. python benchmarks/bench_sweep.py [--points K] [--contacts L] [--repeats R]

The points are DNS probes of the bifurcation sweep (Van der Pol chain, vdp-mu3-v2.3,
mu spread over [1.8, 3], v0 = 2.3, a moving-window DNS to contact L, rtol 1e-8): the same task
the ``pulsemap bifurcation`` command runs. Each configuration runs the whole list of points
without an output file (nothing skipped); the best wall time of R repeats is kept. Printed:
points per second of each executor and the ratio 2 processes / serial, with the machine's CPU
count and load average (other processes on a shared machine lower the ratio). Serial and pool
runs alternate. The results of the two executors are checked to be identical.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from pulsemap.solvers.studies.points import dns_task, plain_chain
from pulsemap.solvers.data.scene import load_scene, with_overrides
from pulsemap.solvers.studies.sweep import run_sweep


def points(k: int, last: int) -> list[dict]:
    chain = plain_chain(with_overrides(load_scene("vdp-mu3-v2.3"), contacts=(16, last)), window="auto", rtol=1e-8)
    return [{**chain, "params": {"mu": float(mu)}} for mu in np.linspace(1.8, 3.0, k)]


def timed(pts: list[dict], **kw) -> tuple[float, list]:
    t0 = time.perf_counter()
    res = run_sweep(dns_task, pts, None, **kw)
    return time.perf_counter() - t0, res.results()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=12)
    ap.add_argument("--contacts", type=int, default=150)
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()
    pts = points(args.points, args.contacts)
    run_sweep(dns_task, pts[:1], None, max_workers=1)  # warm up: imports, generated code
    serial_times, pool_times, same = [], [], True
    for _ in range(args.repeats):  # interleaved, so that a change of the machine's load hits both
        t, ref = timed(pts, max_workers=1)
        serial_times.append(t)
        t, got = timed(pts, max_workers=2)
        pool_times.append(t)
        same = same and got == ref
    serial, pool = min(serial_times), min(pool_times)
    print(f"sweep of {len(pts)} DNS points (Van der Pol, contacts 15..{args.contacts}), best of {args.repeats}; "
          f"cpus {os.cpu_count()}, load average {os.getloadavg()[0]:.2f}")
    print(f"  serial (this process)  : {serial:7.2f} s  {len(pts) / serial:6.2f} points/s")
    print(f"  process pool, 2 workers: {pool:7.2f} s  {len(pts) / pool:6.2f} points/s")
    print(f"  throughput ratio 2 processes / serial: {serial / pool:.2f}  (results identical: {same})")


if __name__ == "__main__":
    main()
