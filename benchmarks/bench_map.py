"""Benchmark: the amplitude map (Eq. 23) per contact, reference Newton vs the compiled kernel.

Run: python benchmarks/bench_map.py
Prints, measured in this run (best of several after a warm-up): microseconds per contact for one
chain with the Python reference and with the compiled kernel, and their ratio. Target: one chain
<= 1 us per contact.
"""

from __future__ import annotations

import time

from pulsemap.solvers.data.scene import load_scene
from pulsemap.solvers.models import codeload
from pulsemap.solvers.models.map_iteration import iterate_map
from pulsemap.solvers.studies.scene_chain import parameter_values

CONTACTS = 2000


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
    print(f"map, vdp-mu3-v2.3 (paper variant), first compiled call in this process {first:.3f} s (kernel load or JIT)")
    print(f"  one chain, python reference : {py * 1e6:8.3f} us/contact")
    print(f"  one chain, compiled kernel  : {cc * 1e6:8.3f} us/contact   (target <= 1 us)   python/compiled {py / cc:6.1f}x")


if __name__ == "__main__":
    main()
