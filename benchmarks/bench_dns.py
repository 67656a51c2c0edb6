"""Speed at equal peak accuracy of the DNS of paper Eq. 1: pulsemap vs two baselines, one run.

Run: PYTHONPATH=. python benchmarks/bench_dns.py [--quick] [--damped] [--repeats K]

N = 1000 beads, v0 = 1, n = 1.5, contacts 16..990, unperturbed (--damped: F = -eps*mu*v,
eps*mu = 0.01 from bead 16). Reference: full chain, DOP853, rtol 1e-12 (convergence checked
against rtol 1e-11). Error = max relative peak difference over the contacts. Every line (method
and mode over a tolerance ladder) is timed warm-up + best of K and its cost at 1e-6 is
interpolated log-log between the two runs that bracket it (pulsemap.solvers.studies.bench.cost_at):

* pulsemap: simulate(..., window="auto"), DOP853 and RK45 (Hairer's Fortran codes);
* baseline (b): simulate(..., window=None), the full-chain vectorised DNS, DOP853 and RK45;
* baseline (a): pulsemap.solvers.studies.bench.baselines.baseline_script (loop RHS, solve_ivp RK45, peaks off a
  t_eval grid) at N = 1000 itself, integrated in grid segments so its 2N x samples grid fits in
  memory (same grid and peaks as one call). It is slow (minutes per run): one run per setting.
  If no setting reaches 1e-6, the ratio printed is a lower bound: (a)'s measured time (which
  did not reach 1e-6) over pulsemap's cost at 1e-6.
"""

from __future__ import annotations

import sys

import numpy as np

from pulsemap.solvers.studies.bench.baselines import baseline_script
from pulsemap.solvers.studies.bench import Point, best_of, cost_at
from pulsemap.solvers.studies.bench import peak_error as _peak_error
from pulsemap.solvers.chain.dns import Chain, Integrator, OnSiteForce, simulate
from pulsemap.solvers.studies.extent import on_contacts

TARGET = 1e-6
N, FIRST, EXPONENT = 1000, 16, 1.5


def damping(eps_mu: float, beads: int, first: int = FIRST) -> OnSiteForce:
    """F = -eps*mu*v on beads >= first, restrictable to the window."""
    mask = (np.arange(1, beads + 1) >= first).astype(float)

    def make(m: np.ndarray) -> OnSiteForce:
        return OnSiteForce(lambda x, v: -eps_mu * m * v, lambda x, v: np.zeros(len(m)),
                           lambda x, v: -eps_mu * m, stiffness_hint=eps_mu)

    full = make(mask)
    return OnSiteForce(full.force, full.dforce_dx, full.dforce_dv, eps_mu,
                       restrict=lambda lo, hi: make(mask[lo:hi]))


def peak_error(res, ref) -> tuple[float | None, int]:
    """pulsemap.solvers.studies.bench.peak_error of a DNS or baseline result against ``ref`` on its live contacts."""
    def live(r):
        return on_contacts(ref.contacts, r.contacts, r.peaks, r.alive)

    return _peak_error(live(res), live(ref))


def line(label: str, run, rtols, ref, repeats: int) -> list[Point]:
    pts = []
    for rtol in rtols:
        res, best = best_of(lambda: (lambda r: (r, r.wall_time_s))(run(rtol)), repeats)
        err, missing = peak_error(res, ref)
        pts.append(Point("dns", label, f"rtol {rtol:g}", rtol, err, missing, best, int(res.nfev)))
        print(f"  {label:22s} rtol {rtol:7.1e} err {err:9.2e} missing {missing:3d} nfev {res.nfev:7d} "
              f"time {best:8.3f} s", flush=True)
    return pts


def main(argv: list[str]) -> None:
    quick = "--quick" in argv
    repeats = int(argv[argv.index("--repeats") + 1]) if "--repeats" in argv else (1 if quick else 3)
    eps_mu = 0.01 if "--damped" in argv else 0.0
    force = damping(eps_mu, N) if eps_mu else None
    force_py = (lambda i, x, v: -eps_mu * v if i >= FIRST else 0.0) if eps_mu else None
    last = N - 10
    ref = simulate(Chain(N, EXPONENT, 1.0, force), (FIRST, last),
                   integrator=Integrator(method="DOP853", rtol=1e-12, atol=1e-14, engine="scipy"))
    check = simulate(Chain(N, EXPONENT, 1.0, force), (FIRST, last),
                     integrator=Integrator(method="DOP853", rtol=1e-11, atol=1e-13, engine="scipy"))
    conv, _ = peak_error(check, ref)
    label = f"damped eps*mu={eps_mu}" if eps_mu else "unperturbed"
    print(f"N={N} {label}, contacts {FIRST}..{last}; reference DOP853 full chain rtol 1e-12: "
          f"{ref.stop_reason}, {ref.alive.sum()} peaks, {ref.wall_time_s:.1f} s; converged to {conv:.1e} "
          f"(vs rtol 1e-11); target max rel error {TARGET:g}; best of {repeats} after a warm-up", flush=True)

    costs = {}
    win_rtols = (1e-6, 1e-7, 3e-8, 1e-8, 1e-9) if not quick else (1e-7, 1e-8)
    full_rtols = (1e-7, 1e-8, 1e-9, 1e-10) if not quick else (1e-8, 1e-9)
    for method in ("DOP853", "RK45"):
        for window, rtols, kind in (("auto", win_rtols, "pulsemap window"), (None, full_rtols, "(b) full chain")):
            lab = f"{kind} {method}"
            pts = line(lab, lambda r, m=method, w=window: simulate(Chain(N, EXPONENT, 1.0, force), (FIRST, last),
                                                                   integrator=Integrator(method=m, rtol=r, atol=r * 1e-2, engine="scipy"),
                                                                   window=w),
                rtols if method == "DOP853" else tuple(r / 10 for r in rtols), ref, repeats)
            costs[lab] = cost_at(pts, TARGET)
            print(f"  -> {lab}: {costs[lab][0] if costs[lab][0] else float('nan'):.3f} s at {TARGET:g} "
                  f"({costs[lab][1]})", flush=True)

    a_pts = []
    t_end = float(np.nanmax(ref.peak_times)) + 3.0
    for rtol, dt in (((1e-8, 0.005),) if quick else ((1e-8, 0.005), (1e-10, 0.0025))):
        r = baseline_script(N, EXPONENT, 1.0, (FIRST, last), force_py, rtol=rtol, atol=rtol * 1e-2,
                            dt_sample=dt, t_end=t_end, segment_samples=4000)
        err, missing = peak_error(r, ref)
        a_pts.append(Point("baseline-a", "script", f"rtol {rtol:g} dt {dt:g}", rtol, err, missing, r.wall_time_s))
        print(f"  (a) user script N={N} rtol {rtol:.0e} dt {dt:g}: err {err:.2e} missing {missing} "
              f"time {r.wall_time_s:.1f} s (one run)", flush=True)
    a_cost, a_how = cost_at(a_pts, TARGET)

    win = min((c[0], k) for k, c in costs.items() if k.startswith("pulsemap") and c[0])
    full = min((c[0], k) for k, c in costs.items() if k.startswith("(b)") and c[0])
    print(f"\nAt N={N}, max relative peak error {TARGET:g} (log-log interpolation on each line):")
    print(f"  pulsemap DNS   {win[0]:8.3f} s  ({win[1]})")
    print(f"  baseline (b)   {full[0]:8.3f} s  ({full[1]})   ratio (b)/pulsemap = {full[0] / win[0]:6.2f}x")
    if a_cost:
        print(f"  baseline (a)   {a_cost:8.1f} s  ({a_how})   ratio (a)/pulsemap = {a_cost / win[0]:6.0f}x")
    else:
        best_a = min(a_pts, key=lambda p: p.error)
        print(f"  baseline (a)   did not reach {TARGET:g} (best {best_a.error:.2e} in {best_a.time_s:.1f} s): "
              f"ratio (a)/pulsemap >= {best_a.time_s / win[0]:6.0f}x (lower bound)")


if __name__ == "__main__":
    main(sys.argv[1:])
