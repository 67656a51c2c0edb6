"""Cost of the DNS of paper Eq. 1 against chain length: moving window vs full chain.

Run: PYTHONPATH=. python benchmarks/bench_dns_scaling.py [--repeats R] [--calibrate]

v0 = 1, n = 1.5, contacts 16..N-10, N = 1000 and 4000, default tolerances (DOP853 rtol 1e-10),
unperturbed and damped (F = -eps*mu*v, eps*mu = 0.01, from bead 16). Prints the best of R
wall times and the ratio time(N=4000)/time(N=1000): about 4 when the cost per contact does not
grow with N, 16 for O(N) work per contact. Note: with eps*mu = 0.01 the pulse dies (peak below
1e-3 of contact 16's) near contact 643, so both chain lengths stop there.

--calibrate re-measures the error the window costs against the full chain for several numbers
of beads kept behind the front (docs/dns.rst, "Window calibration").
"""

from __future__ import annotations

import sys

import numpy as np

from bench_dns import damping, peak_error  # the sibling script (its directory is on sys.path)
from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.chain.window import WindowRule


def best(repeats: int, *args, **kwargs):
    """Fastest of ``repeats`` runs of simulate()."""
    return min((simulate(*args, **kwargs) for _ in range(repeats)), key=lambda r: r.wall_time_s)


def scaling(repeats: int) -> None:
    print(f"{'case':12s} {'mode':8s} {'N':>5s} {'wall_s':>8s} {'nfev':>8s} {'beads_int':>9s}  stop")
    for label, eps_mu in (("unperturbed", 0.0), ("damped0.01", 0.01)):
        for window in ("auto", None):
            t = {}
            for n_beads in (1000, 4000):
                force = damping(eps_mu, n_beads) if eps_mu else None
                r = best(repeats if (window or n_beads == 1000) else max(1, repeats - 1),
                         Chain(n_beads, 1.5, 1.0, force), (16, n_beads - 10), window=window)
                t[n_beads] = r.wall_time_s
                mode = "window" if window else "full"
                print(f"{label:12s} {mode:8s} {n_beads:5d} {r.wall_time_s:8.2f} {r.nfev:8d} "
                      f"{r.window_beads:9d}  {r.stop_reason[:48]}", flush=True)
            print(f"  -> {label} {mode}: time(N=4000)/time(N=1000) = {t[4000] / t[1000]:.2f}", flush=True)


def calibrate() -> None:
    beads, last = 200, 190
    tight = Integrator(method="DOP853", rtol=1e-13, atol=1e-15)
    print("max relative peak error of the window vs the full chain (contacts 1..190)")
    for eps_mu in (0.0, 0.01, 0.05, 0.1, 0.3):
        force = damping(eps_mu, beads) if eps_mu else None
        ref = simulate(Chain(beads, 1.5, 1.0, force), (1, last), integrator=tight)
        row = []
        for behind in (4, 6, 8, 12, 16, 20, 24):
            for boundary in ("coast", "free"):
                w = simulate(Chain(beads, 1.5, 1.0, force), (1, last),
                             integrator=tight, window=WindowRule(behind=behind, boundary=boundary))
                err, _ = peak_error(w, ref)
                same = bool(np.array_equal(ref.alive, w.alive))
                row.append(f"{behind}/{boundary}:{err:.1e}{'' if same else '!'}")
        print(f"eps*mu={eps_mu:<5g} " + " ".join(row), flush=True)


def main(argv: list[str]) -> None:
    repeats = int(argv[argv.index("--repeats") + 1]) if "--repeats" in argv else 3
    if "--calibrate" in argv:
        calibrate()
    else:
        scaling(repeats)


if __name__ == "__main__":
    main(sys.argv[1:])
