"""What the non-finite check and the unperturbed-bead skip of the on-site force cost, measured in one run.

Run: PULSEMAP_CACHE_DIR=... python benchmarks/bench_onsite_check.py [--repeats K]

fig8-eps0.1's chain (first_perturbed 16) with R = -mu*v and -mu*sin(u), the scipy engine's view of
paper Eq. 1's force on a moving window of 40 beads. Printed, best of K (20,000 calls each):
1. the force as the DNS calls it (models/onsite.py: beads with eps_i = 0 sliced off, a finiteness test
   that raises ForceNotFinite) against the generated module called bare on the same window (the
   module skips those beads itself; where every bead is perturbed it is the expression alone), on a
   window of perturbed beads only and on one holding beads 1..15;
2. the scipy engine's right-hand side (chain/equations.make_rhs) with that force, for scale;
3. the whole scipy-engine DNS of the scene (moving window, DOP853, rtol 1e-8).
The compiled engine's part (a test of eps_i at the top of the numba force, a NaN test on the
rejected-step branch of the kernels) is timed by benchmarks/bench_nonpoly.py.
"""

from __future__ import annotations

import sys
import time
import timeit

import numpy as np

from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.chain.equations import make_rhs
from pulsemap.solvers.data.scene import load_scene, with_overrides
from pulsemap.solvers.models.codeload import force_module
from pulsemap.solvers.studies.extent import dns_span
from pulsemap.solvers.studies.scene_chain import make_force

CALLS = 20_000


def best(fn, repeats: int) -> float:
    return min(timeit.repeat(fn, number=CALLS, repeat=repeats)) / CALLS


def main(argv: list[str]) -> None:
    repeats = int(argv[argv.index("--repeats") + 1]) if "--repeats" in argv else 5
    rng = np.random.default_rng(1)
    for R in ("-mu*v", "-mu*sin(u)"):
        scene = with_overrides(load_scene("fig8-eps0.1"), R=R, params={"mu": 1.0})
        beads, span = dns_span(scene)
        force = make_force(scene, beads)
        module = force_module(R, ["mu"])
        print(f"R = {R}")
        for lo, hi in ((0, 40), (20, 60)):
            on = force.restrict(lo, hi)
            i = np.arange(lo + 1, hi + 1, dtype=float)
            eps = np.where(i >= scene.first_perturbed, scene.perturbation.eps, 0.0)
            x, v = rng.uniform(0, 1, hi - lo), rng.uniform(0, 1, hi - lo)
            assert np.array_equal(on.force(x, v), module.force(x, v, i, eps, 1.0))
            checked = best(lambda: on.force(x, v), repeats)
            bare = best(lambda: module.force(x, v, i, eps, 1.0), repeats)
            rhs = make_rhs(hi - lo, scene.exponent, on, wall=True)
            y = np.empty(2 * (hi - lo))
            y[0::2], y[1::2] = x, v
            t_rhs = best(lambda: rhs(0.0, y), repeats)
            print(f"  beads {lo + 1}..{hi}: force as the DNS calls it {checked * 1e6:6.2f} us | generated module bare "
                  f"{bare * 1e6:6.2f} us | ratio {checked / bare:5.2f} | the RHS with it {t_rhs * 1e6:6.2f} us")
        t0 = time.perf_counter()
        for _ in range(repeats):
            simulate(Chain(beads, scene.exponent, scene.velocity, force), span,
                     integrator=Integrator(engine="scipy", rtol=1e-8), window="auto")
        print(f"  scipy-engine DNS (window, DOP853, rtol 1e-8): {(time.perf_counter() - t0) / repeats * 1e3:.1f} ms")


if __name__ == "__main__":
    main(sys.argv[1:])
