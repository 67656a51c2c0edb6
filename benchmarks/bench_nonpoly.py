"""Non-polynomial R on the compiled engine (a generated numba force, derive/codegen_jitforce.py) vs the
scipy engine that ran it before, and what the first run costs.

Run: PULSEMAP_CACHE_DIR=... python benchmarks/bench_nonpoly.py [--repeats K] [--skip-cold]

fig8-eps0.1's chain (eps 0.1, contacts 15..120, moving window) with R = -mu*sin(u), -mu*v/(1+v^2)
and -mu*sin(u)*exp(-v^2) (mu = 1), the stiff -mu*v/(1+v^2) with mu = 10000 (eps mu = 1000: Rodas4 against
LSODA), and two non-smooth R: Coulomb friction -mu*sign(v) with mu = 0.2 (its ramp: Rodas4 against BDF)
and -mu*v*abs(v) (mu = 1). Printed, all in one run, best of K after a warm-up: each engine's time at rtol
1e-6 and 1e-8 (the scipy engine's own choice of method), each one's max relative peak error against the
scipy engine (DOP853, Radau when stiff, BDF through a ramp) at rtol 1e-11, and the ratio scipy / compiled. Then the
whole-process CPU time of one such DNS: empty numba and pulsemap caches (code generation and JIT),
both filled, and a new R with the kernel cached (code generation and the force's JIT only).
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

CASES = (("-mu*sin(u)", 1.0, "DOP853"), ("-mu*v/(1+v^2)", 1.0, "DOP853"), ("-mu*sin(u)*exp(-v^2)", 1.0, "DOP853"),
         ("-mu*v/(1+v^2)", 10000.0, "Radau"), ("-mu*sign(v)", 0.2, "BDF"), ("-mu*v*abs(v)", 1.0, "DOP853"))
ONE_RUN = """
import sys, time
t0 = time.process_time()
from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.data.scene import load_scene, with_overrides
from pulsemap.solvers.studies.extent import dns_span
from pulsemap.solvers.studies.scene_chain import make_force
scene = with_overrides(load_scene("fig8-eps0.1"), R=sys.argv[1], params={"mu": 1.0})
beads, span = dns_span(scene)
res = simulate(Chain(beads, scene.exponent, scene.velocity, make_force(scene, beads)), span, window="auto",
               integrator=Integrator(rtol=1e-8))
assert res.engine == "compiled", res.engine_reason
print(time.process_time() - t0)
"""


def peak_error(res, ref) -> float:
    if not np.array_equal(res.alive, ref.alive) or not ref.alive.any():
        return float("nan")
    return float(np.max(np.abs(res.peaks[ref.alive] / ref.peaks[ref.alive] - 1.0)))


def engines(repeats: int) -> None:
    print("1. compiled (numba force) vs scipy engine, fig8-eps0.1's chain, moving window")
    for R, mu, reference in CASES:
        scene = with_overrides(load_scene("fig8-eps0.1"), R=R, params={"mu": mu})
        beads, span = dns_span(scene)
        force = make_force(scene, beads)

        def run(**kw):
            def timed():
                t0 = time.perf_counter()
                res = simulate(Chain(beads, scene.exponent, scene.velocity, force), span,
                               integrator=Integrator(**kw), window="auto")
                return res, time.perf_counter() - t0
            return timed

        ref = run(engine="scipy", method=reference, rtol=1e-11, atol=1e-13)()[0]
        for rtol in (1e-6, 1e-8):
            tol = dict(rtol=rtol, atol=rtol * 1e-2)
            fast, t_fast = best_of(run(**tol), repeats)
            slow, t_slow = best_of(run(engine="scipy", **tol), repeats)
            print(f"  {R:22s} mu {mu:6g} rtol {rtol:.0e}: compiled {fast.method} {t_fast * 1e3:7.2f} ms "
                  f"(err {peak_error(fast, ref):.1e}) | scipy {slow.method} {t_slow * 1e3:7.1f} ms "
                  f"(err {peak_error(slow, ref):.1e}) | ratio {t_slow / t_fast:6.1f}x  [{ref.alive.sum()} live]")


def cold() -> None:
    print("2. one non-polynomial DNS, whole-process CPU time")

    def cpu(R: str, env: dict) -> float:
        out = subprocess.run([sys.executable, "-c", ONE_RUN, R], env=env, check=True, capture_output=True, text=True)
        return float(out.stdout.split()[-1])

    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "NUMBA_CACHE_DIR": str(Path(tmp) / "numba"), "PULSEMAP_CACHE_DIR": str(Path(tmp) / "pm")}
        first, again = cpu("-mu*v/(1+v^2)", env), cpu("-mu*v/(1+v^2)", env)
        new_R = cpu("-mu*tanh(v)", env)
    print(f"  empty caches (codegen + JIT) {first:.2f} s; cached {again:.2f} s; a new R, kernel cached {new_R:.2f} s")


def main(argv: list[str]) -> None:
    repeats = int(argv[argv.index("--repeats") + 1]) if "--repeats" in argv else 3
    engines(repeats)
    if "--skip-cold" not in argv:
        cold()


if __name__ == "__main__":
    main(sys.argv[1:])
