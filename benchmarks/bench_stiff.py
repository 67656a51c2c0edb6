"""Stiff damping vs a non-stiff scene of the same length (issue 6 target: ratio <= 5).

Run: PYTHONPATH=. python benchmarks/bench_stiff.py [--repeats K]

Suite scenes solvers/scenes/suite/damp-{10,100,1000}.toml (R = -mu*v, eps*mu = 10, 100, 1000)
and nonstiff.toml (eps*mu = 0.1), all contacts 16..120, DNS as `pulsemap suite` runs it (moving
window, method 'auto', rtol 1e-8). Best of K after a warm-up; prints each time, the method
chosen, the stop reason and time(stiff)/time(nonstiff). Also the stiff scenes forced onto the
explicit DOP853, to show what the implicit choice buys.
"""

from __future__ import annotations

import sys

from pulsemap.solvers.studies.bench import best_of
from pulsemap.solvers.studies.run import run_scene
from pulsemap.solvers.data.scene import load_scene
from pulsemap.solvers.studies.suite import resolve


def timed(scene, method: str | None = None):
    s = scene if method is None else scene.with_overrides(dns={"method": method})
    out = run_scene(s, methods=["dns"], dns_window="auto")
    return out, out["timings_s"]["dns"]


def main(argv: list[str]) -> None:
    repeats = int(argv[argv.index("--repeats") + 1]) if "--repeats" in argv else 3
    base_out, base = best_of(lambda: timed(load_scene(resolve("nonstiff"))), repeats)
    print(f"nonstiff  (eps*mu = 0.1): {base:.4f} s  {base_out['dns']['method']}  {base_out['dns']['stop_reason']}")
    for name in ("damp-10", "damp-100", "damp-1000"):
        scene = load_scene(resolve(name))
        out, t = best_of(lambda: timed(scene), repeats)
        _, t_exp = best_of(lambda: timed(scene, "DOP853"), repeats)
        print(f"{name:9s}: {t:.4f} s  {out['dns']['method']:6s} ratio to nonstiff {t / base:5.2f}  "
              f"(DOP853 forced: {t_exp:.4f} s)  {out['dns']['stop_reason']}")
    print("target: damp-100 within 5x of nonstiff")


if __name__ == "__main__":
    main(sys.argv[1:])
