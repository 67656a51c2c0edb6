"""Benchmark: the relaxed map's cost, building its tables for a new R (cold cache) and iterating it.

Run: python benchmarks/bench_relaxed.py [SCENE ...]
Prints, measured in this run: per scene the time to build the tables from an empty cache (the
segment runs, DNS with the moving window), the number of segment runs, the time to build them
again from the cache, and the time per contact of the iteration (best of 5), next to the scene's
DNS integration time (ms; its kernel compile is apart, in ``dns_compile``). Target: building <= 30 s on 2 cores, cached afterwards.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time

from pulsemap.solvers.data.scene import load_scene
from pulsemap.solvers.models.relaxed import iterate_relaxed, model_for_scene
from pulsemap.solvers.studies.scene_chain import parameter_values
from pulsemap.solvers.studies.run import run_scene

SCENES = ["fig6-eps0.3", "fig7-eps0.3", "fig8-eps0.3", "vdp-mu3-v2.3"]


def main(names: list[str]) -> None:
    print(f"{'scene':14s} {'build cold s':>12s} {'runs':>5s} {'build warm s':>12s} {'us/contact':>10s} {'DNS ms':>7s}")
    for name in names:
        scene = load_scene(name)
        with tempfile.TemporaryDirectory() as tmp:
            os.environ["PULSEMAP_CACHE_DIR"] = tmp
            ref = run_scene(scene, methods=["dns"])
            seed, c0, c1 = ref["dns"]["seed_peak"], scene.first_perturbed - 1, scene.contacts[1]
            prm = parameter_values(scene, scene.beads)
            t0 = time.perf_counter()
            model = model_for_scene(scene, prm)
            run = iterate_relaxed(model, seed, c0, c1)  # the tables grow as the iteration needs them
            cold = time.perf_counter() - t0
            t0 = time.perf_counter()
            warm_model = model_for_scene(scene, prm)
            iterate_relaxed(warm_model, seed, c0, c1)
            warm = time.perf_counter() - t0
            best = min(_timed(lambda: iterate_relaxed(warm_model, seed, c0, c1)) for _ in range(5))
            per = 1e6 * best / max(1, len(run.contacts))
            print(f"{name:14s} {cold:12.2f} {model.segment_runs():5d} {warm:12.3f} {per:10.1f} "
                  f"{1e3 * ref['timings_s']['dns']:7.2f}")


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


if __name__ == "__main__":
    main(sys.argv[1:] or SCENES)
