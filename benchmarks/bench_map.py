"""Benchmark: the amplitude map (Eq. 23) per contact, reference Newton vs the compiled kernel.

Run: python benchmarks/bench_map.py
Prints, measured in this run (best of several after a warm-up): microseconds per contact for one
chain with the Python reference and with the compiled kernel, per chain-contact for 1024 chains in
one call (on one numba thread and on all of them, same contacts as the single chain), and the
ratios. Targets: one chain <= 1 us per contact, 1024 chains <= 0.2 us. The threaded
figure needs idle cores: the load average is printed beside it.
"""

from __future__ import annotations

import os
import time

import numba
import numpy as np

from pulsemap.solvers.data.scene import load_scene
from pulsemap.solvers.models import codeload
from pulsemap.solvers.models.map_iteration import iterate_map, iterate_map_many
from pulsemap.solvers.studies.forcing import parameter_values

CONTACTS = 2000
CHAINS = 1024


def best(fn, repeat: int = 5) -> float:
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    scene = load_scene("vdp-mu3-v2.3")
    prm = parameter_values(scene, scene.beads)
    mod = codeload.map_module(scene.perturbation.R, list(scene.perturbation.params), scene.exponent, "exact", "paper")
    eps = float(scene.perturbation.eps)
    t0 = time.perf_counter()
    iterate_map(mod, 0.6, 15, 20, eps, prm, engine="compiled")
    first = time.perf_counter() - t0
    py = best(lambda: iterate_map(mod, 0.6, 15, 15 + CONTACTS, eps, prm, engine="python"), 3) / CONTACTS
    cc = best(lambda: iterate_map(mod, 0.6, 15, 15 + CONTACTS, eps, prm, engine="compiled")) / CONTACTS
    mus = np.linspace(2.0, 4.0, CHAINS)
    params = [{**prm, "mu": float(m)} for m in mus]
    seeds = np.full(CHAINS, 0.6)
    iterate_map_many(mod, seeds[:2], 15, 20, eps, params[:2])
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    one = best(lambda: iterate_map_many(mod, seeds, 15, 15 + CONTACTS, eps, params), 2) / (CHAINS * CONTACTS)
    numba.set_num_threads(threads)
    many = best(lambda: iterate_map_many(mod, seeds, 15, 15 + CONTACTS, eps, params), 2) / (CHAINS * CONTACTS)
    print(f"map, vdp-mu3-v2.3 (paper variant), first compiled call in this process {first:.3f} s (kernel load or JIT)")
    print(f"  one chain, python reference : {py * 1e6:8.3f} us/contact")
    print(f"  one chain, compiled kernel  : {cc * 1e6:8.3f} us/contact   (target <= 1 us)   python/compiled {py / cc:6.1f}x")
    print(f"  {CHAINS} chains, 1 thread     : {one * 1e6:8.3f} us/chain-contact")
    print(f"  {CHAINS} chains, {threads} threads    : {many * 1e6:8.3f} us/chain-contact (target <= 0.2 us)  python/batch "
          f"{py / many:6.1f}x, 1 thread/{threads} threads {one / many:4.2f}x; load average {os.getloadavg()[0]:.1f} "
          f"on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
