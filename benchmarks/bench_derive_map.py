"""Benchmarks: cold derivation of a new cubic perturbation; the ``pulsemap derive`` process cold and
warm; 100 contacts of the generated map.

Run: python benchmarks/bench_derive_map.py
Prints times (best of several runs after a warm-up) and the ratios cold / warm and DNS / map,
measured in this run.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
import timeit

COLD = r"""
import time
t0 = time.perf_counter()
from pulsemap.symbolic.perturbation import make_perturbation
from pulsemap.symbolic.derivation import derive_all
t1 = time.perf_counter()
d = derive_all(make_perturbation({expr!r}, 0.1, {params!r}), sympy_seconds={bound})
t2 = time.perf_counter()
print(f"{{t1 - t0:.3f}} {{t2 - t1:.3f}} {{d.longwave.kind}}")
"""


def cold_derive(expr: str, params: dict, bound: float = 2.0) -> tuple[float, float, str]:
    """(import time, derivation time, law kind) in a fresh process with an empty cache."""
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "PULSEMAP_CACHE_DIR": cache}
        out = subprocess.run([sys.executable, "-c", COLD.format(expr=expr, params=params, bound=bound)],
                             capture_output=True, text=True, env=env, check=True)
    imp, der, kind = out.stdout.strip().split(" ", 2)
    return float(imp), float(der), kind


def cli_derive(args: list[str], repeat: int = 3) -> tuple[float, float]:
    """(cold, best warm) wall time of the ``pulsemap derive`` process: first with an empty cache, then
    again with the cache that run filled (the sympy time-outs are cached too, so warm skips them)."""
    exe = os.path.join(os.path.dirname(sys.executable), "pulsemap")
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "PULSEMAP_CACHE_DIR": cache}
        times = []
        for _ in range(1 + repeat):
            t0 = time.perf_counter()
            subprocess.run([exe, "derive", *args, "--quiet"], capture_output=True, env=env, check=True)
            times.append(time.perf_counter() - t0)
    return times[0], min(times[1:])


def main() -> None:
    print("pulsemap derive, whole process (cold: empty cache; warm: best of 3 after it):")
    for args in (["-mu*v", "--param", "mu=1"], ["-(u - mu*(1 - u^2)*v)", "--param", "mu=3"], ["(u+v+1)^8-1"]):
        cold, warm = cli_derive(args)
        print(f"  {' '.join(args):36s} cold {cold:6.2f} s   warm {warm:5.2f} s   cold/warm {cold / warm:5.1f}")
    print("cold derivation (empty cache, fresh process):")
    for expr, params in (("gamma*u^3", {"gamma": -0.5}), ("a*u^3 + b*u*v^2", {"a": -1, "b": 0.5})):
        imp, der, kind = cold_derive(expr, params)
        print(f"  R = {expr:18s} derive {der:.3f} s (+ imports {imp:.3f} s), law: {kind}")

    from pulsemap.solvers.models.codeload import map_module
    from pulsemap.solvers.models.map_iteration import iterate_map
    from pulsemap.solvers.studies.run import run_scene
    from pulsemap.solvers.data.scene import load_scene, with_overrides

    scene = with_overrides(load_scene("vdp-mu3-v2.3"), contacts=(16, 115))
    mod = map_module(scene.perturbation.text, ["mu"], 1.5, "exact", "paper")
    call = lambda: iterate_map(mod, 0.9, 15, 115, 0.1, {"mu": 3.0})  # noqa: E731
    call()
    best_map = min(timeit.repeat(call, number=20, repeat=5)) / 20
    t0 = time.perf_counter()
    res = run_scene(scene, methods=["dns"])
    dns = res["timings_s"]["dns"]
    print(f"map, 100 contacts (generated code, Newton): {best_map * 1e3:.3f} ms")
    print(f"DNS of the same scene ({res['dns']['method']}, rtol {res['dns']['rtol']:g}, {res['dns']['beads']} beads): "
          f"{dns:.3f} s  (wall {time.perf_counter() - t0:.3f} s)")
    print(f"ratio DNS / map = {dns / best_map:.0f}")


if __name__ == "__main__":
    main()
