"""Work-precision of the DNS (paper Eq. 1): 140-bead chain, v0 = 1, contacts 1..120.

Run: PYTHONPATH=. python benchmarks/bench_dns.py [--quick]. Minimum wall time over repeats,
error = max relative peak difference against DOP853 at rtol 1e-12.
"""

from __future__ import annotations

import sys

import numpy as np

from solvers.dns import OnSiteForce, simulate

BEADS, LAST, EXPONENT = 140, 120, 1.5


def damping(eps_mu: float, beads: int = BEADS, first: int = 16) -> OnSiteForce:
    """F = -eps*mu*v on beads >= first, analytic Jacobian."""
    mask = (np.arange(1, beads + 1) >= first).astype(float)
    return OnSiteForce(lambda x, v: -eps_mu * mask * v, lambda x, v: np.zeros(beads),
                       lambda x, v: -eps_mu * mask, stiffness_hint=eps_mu)


def best_of(repeats: int, **kwargs):
    """Run simulate() ``repeats`` times (after the first) and keep the fastest."""
    runs = [simulate(**kwargs) for _ in range(repeats)]
    return min(runs, key=lambda r: r.wall_time_s)


def table(force: OnSiteForce | None, label: str, methods, rtols, repeats: int) -> None:
    base = dict(beads=BEADS, exponent=EXPONENT, velocity=1.0, contacts=(1, LAST), force=force)
    ref = simulate(**base, method="DOP853", rtol=1e-12, atol=1e-14)
    print(f"\n{label}: reference stop: {ref.stop_reason}")
    print(f"{'method':8s} {'rtol':>7s} {'wall_s':>8s} {'nfev':>8s} {'njev':>5s} {'max_rel_err':>11s}  drift")
    for method in methods:
        for rtol in rtols:
            r = best_of(repeats, **base, method=method, rtol=rtol, atol=rtol * 1e-2)
            both = r.alive & ref.alive
            err = float(np.max(np.abs(r.peaks[both] / ref.peaks[both] - 1)))
            drift = "-" if r.energy_drift is None else f"{r.energy_drift:.1e}"
            print(f"{method:8s} {rtol:7.0e} {r.wall_time_s:8.2f} {r.nfev:8d} {r.njev:5d} {err:11.2e}  {drift}")


def main(argv: list[str]) -> None:
    quick = "--quick" in argv
    rtols = [1e-10] if quick else [1e-8, 1e-10]
    repeats = 1 if quick else 3
    methods = ["DOP853", "LSODA", "BDF", "Radau"]
    table(None, "unperturbed", methods, rtols, repeats)
    table(damping(0.3), "damped eps*mu=0.3 from bead 16", methods, rtols, repeats)


if __name__ == "__main__":
    main(sys.argv[1:])
