"""Stiff scenes: the compiled Rosenbrock engine vs the scipy stiff engine, and stiff vs non-stiff time.

Run: PULSEMAP_CACHE_DIR=... python benchmarks/bench_stiff.py [--repeats K] [--skip-cold]

Suite scenes solvers/scenes/suite/damp-{10,100,1000}.toml (R = -mu*v, eps*mu = 10, 100, 1000),
stiff-foundation.toml (R = -k*u, eps*k = 1000) and nonstiff.toml (eps*mu = 0.1). Best of K after a
warm-up, all in one run. Printed:

1. per stiff scene (the scipy engine's 'auto' finds it stiff; also damp-100 and stiff-foundation made
   stiffer, eps 1 and 10), contacts 1 .. first_perturbed + 20, moving window: the compiled engine's
   choice under 'auto' (Rodas4, compiled_stiff.py, above 300x the contact rate; else Dormand-Prince,
   which is cheaper there) against the scipy engine's choice (LSODA with the banded analytic
   Jacobian) and scipy's Radau at the same rtol; each one's max relative peak error against Radau at
   rtol 1e-11 and the time ratios scipy / compiled;
2. the cold cost of the stiff kernel: a fresh process with an empty numba cache (JIT) and a second
   one with the cache filled, each running one small stiff DNS (CPU time of the whole process);
3. the DNS time of `pulsemap suite`'s runs (run_scene, moving window, method 'auto', rtol 1e-8) of
   the damping scenes against the non-stiff one, and the stiff scenes forced onto DOP853.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.data.scene import load_scene, with_overrides
from pulsemap.solvers.studies.bench import best_of
from pulsemap.solvers.studies.extent import dns_span
from pulsemap.solvers.studies.scene_chain import make_force
from pulsemap.solvers.studies.run import run_scene
from pulsemap.solvers.studies.suite import resolve

STIFF = (("damp-100", {}), ("damp-100", {"eps": 1.0}), ("damp-1000", {}), ("stiff-foundation", {}),
         ("stiff-foundation", {"eps": 10.0}))
RTOLS = (1e-6, 1e-8)
COLD = """
import time
t0 = time.process_time()
from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.chain.equations import OnSiteForce
from pulsemap.solvers.chain.force_table import MonomialTable
table = MonomialTable.of([[0, 1]], [[0.0] * 15 + [-1000.0]])
force = OnSiteForce(lambda x, v: 0 * v, stiffness_hint=1000.0, monomials=table)
res = simulate(Chain(40, 1.5, 1.0, force), (1, 20), window="auto", integrator=Integrator(rtol=1e-6, atol=1e-8))
assert res.method == "Rodas4", res.engine_reason
print(time.process_time() - t0)
"""


def timed(run):
    t0 = time.perf_counter()
    res = run()
    return res, time.perf_counter() - t0


def peak_error(res, ref) -> float:
    both = res.alive & ref.alive
    if not both.any() or not np.array_equal(res.alive, ref.alive):
        return float("nan")
    return float(np.max(np.abs(res.peaks[both] / ref.peaks[both] - 1.0)))


def engines(repeats: int) -> None:
    print("1. the compiled engine's choice under 'auto' (Rodas4 above 300x the contact rate, else Dormand-Prince)\n"
          "   vs the scipy stiff engine (contacts 1 .. first_perturbed + 20, moving window)")
    for name, overrides in STIFF:
        scene = with_overrides(load_scene(resolve(name)), **overrides)
        label = name + "".join(f" {k} {v:g}" for k, v in overrides.items())
        beads, _ = dns_span(scene)
        force = make_force(scene, beads)
        span = (1, scene.first_perturbed + 20)

        def run(**kw):
            return lambda: timed(lambda: simulate(Chain(beads, scene.exponent, scene.velocity, force), span,
                                                  integrator=Integrator(**kw), window="auto"))

        ref = run(engine="scipy", method="Radau", rtol=1e-11, atol=1e-13)()[0]
        for rtol in RTOLS:
            tol = dict(rtol=rtol, atol=rtol * 1e-2)
            fast, t_fast = best_of(run(**tol), repeats)
            lsoda, t_lsoda = best_of(run(engine="scipy", **tol), repeats)
            radau, t_radau = best_of(run(engine="scipy", method="Radau", **tol), max(1, repeats // 3))
            print(f"  {label:22s} rtol {rtol:.0e}: {fast.method} {t_fast * 1e3:7.2f} ms (err {peak_error(fast, ref):.1e}, "
                  f"{fast.steps} steps) | {lsoda.method} {t_lsoda * 1e3:7.2f} ms (err {peak_error(lsoda, ref):.1e}) "
                  f"ratio {t_lsoda / t_fast:5.1f}x | Radau {t_radau * 1e3:7.1f} ms (err {peak_error(radau, ref):.1e}) "
                  f"ratio {t_radau / t_fast:6.1f}x   [{fast.alive.sum()} live contacts]")


def cold() -> None:
    print("2. stiff kernel, whole process CPU time: empty numba cache (JIT) vs filled cache")
    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "NUMBA_CACHE_DIR": str(Path(tmp) / "numba")}
        cpu = [float(subprocess.run([sys.executable, "-c", COLD], env=env, check=True, capture_output=True,
                                    text=True).stdout.split()[-1]) for _ in range(2)]
    print(f"  import + first stiff DNS: cold {cpu[0]:.2f} s CPU, cached {cpu[1]:.2f} s CPU")


def suite_times(repeats: int) -> None:
    def dns_time(scene, method: str | None = None):
        s = scene if method is None else with_overrides(scene, dns={"method": method})
        out = run_scene(s, methods=["dns"], dns_window="auto")
        return out, out["timings_s"]["dns"]

    print("3. pulsemap suite's DNS (rtol 1e-8): stiff vs non-stiff")
    base_out, base = best_of(lambda: dns_time(load_scene(resolve("nonstiff"))), repeats)
    print(f"  nonstiff  (eps*mu = 0.1): {base:.4f} s  {base_out['dns']['method']}  {base_out['dns']['stop_reason']}")
    for name in ("damp-10", "damp-100", "damp-1000"):
        scene = load_scene(resolve(name))
        out, t = best_of(lambda: dns_time(scene), repeats)
        _, t_exp = best_of(lambda: dns_time(scene, "DOP853"), repeats)
        print(f"  {name:9s}: {t:.4f} s  {out['dns']['method']:6s} ratio to nonstiff {t / base:5.2f}  "
              f"(DOP853 forced: {t_exp:.4f} s)  {out['dns']['stop_reason']}")
    print("  target: damp-100 within 5x of nonstiff")


def main(argv: list[str]) -> None:
    repeats = int(argv[argv.index("--repeats") + 1]) if "--repeats" in argv else 3
    engines(repeats)
    if "--skip-cold" not in argv:
        cold()
    suite_times(repeats)


if __name__ == "__main__":
    main(sys.argv[1:])
