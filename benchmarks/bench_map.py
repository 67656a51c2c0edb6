"""Benchmark: the amplitude map (Eq. 23) per contact, reference Newton vs the compiled kernel.

Run: python benchmarks/bench_map.py
Prints, measured in this run (best of several after a warm-up): microseconds per contact for one
chain with the Python reference and with the compiled kernel, per chain-contact for 1024 chains in
one call, and the ratios. Targets (issue 19): one chain <= 1 us per contact, 1024 chains <= 0.2 us.
"""

from __future__ import annotations

import time

import numpy as np

from pulsemap.solvers.data.scene import load_scene
from pulsemap.solvers.models import codeload
from pulsemap.solvers.models.map_iteration import iterate_map, iterate_map_many
from pulsemap.solvers.studies.forcing import _params

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
    prm = _params(scene, scene.beads)
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
    many = best(lambda: iterate_map_many(mod, seeds, 15, 15 + 200, eps, params), 3) / (CHAINS * 200)
    print(f"map, vdp-mu3-v2.3 (paper variant), first compiled call in this process {first:.3f} s (kernel load or JIT)")
    print(f"  one chain, python reference : {py * 1e6:8.3f} us/contact")
    print(f"  one chain, compiled kernel  : {cc * 1e6:8.3f} us/contact   (target <= 1 us)   python/compiled {py / cc:6.1f}x")
    print(f"  {CHAINS} chains in one call     : {many * 1e6:8.3f} us/chain-contact (target <= 0.2 us)  python/batch {py / many:6.1f}x")


if __name__ == "__main__":
    main()
