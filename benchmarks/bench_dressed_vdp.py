"""The dressed law's Van der Pol stationary peak against the DNS: the table of docs/models.rst (dressed law).

Run: python benchmarks/bench_dressed_vdp.py
R = -(u - mu (1 - u^2) v), n = 1.5, beads 1..15 unperturbed, v0 = 2.3, DNS at rtol 1e-10 run until the
peaks settle (contacts 16 .. 20/eps + 100). Printed per (mu, eps): the DNS stationary peak (last contact;
its drift over the last 50 contacts), the stationary peaks of the first-order (energy) law, of the dressed
law and of the dressed law with its calibrated next terms added, their errors against the DNS, the
dressed rate at the DNS's fixed point (what the law misses there: the DNS rate is 0) and the law's estimated
error at the last contact (what ``run`` prints; nan: no value there, its estimate passed 5 %). Last,
the fitted orders in eps of the errors (log2 of successive ratios, eps halving).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

import pulsemap
from pulsemap.symbolic.profile import exact_profile
from pulsemap.solvers.studies.dressed import coefficients

R = "-(u - mu*(1 - u^2)*v)"
LADDER = (0.2, 0.1, 0.05, 0.025, 0.0125, 0.00625)


def roots(f, lo=0.05, hi=20.0):
    grid = np.geomspace(lo, hi, 3000)
    v = np.array([f(a) for a in grid])
    return [brentq(f, grid[k], grid[k + 1]) for k in range(grid.size - 1)
            if np.isfinite(v[k]) and np.isfinite(v[k + 1]) and np.sign(v[k]) != np.sign(v[k + 1])]


def nearest(rs, target):
    return min(rs, key=lambda r: abs(math.log(r / target))) if rs else math.nan


def main() -> None:
    S0 = exact_profile(1.5).S0
    for mu in (3.0, 5.0):
        errs = {"first": [], "dressed": [], "+next": []}
        print(f"mu = {mu:g}")
        print("  eps      DNS peak  (drift)   first    err%   dressed  err%   +next    err%   "
              "rate@DNS   estimate%")
        for eps in LADDER:
            sc = pulsemap.scene("vdp-mu3-v2.3", **{"perturbation.eps": eps, "perturbation.params.mu": mu,
                                                   "output.contacts": [16, int(20 / eps) + 100]})
            res = pulsemap.run(sc, methods=["dns", "dressed-law"]).to_dict()
            dns = [p for p in res["peaks"]["dns"] if p is not None]
            printed = [a for a in res["dressed-law"].get("accuracy") or [] if a is not None]
            P, drift = dns[-1], abs(dns[-1] - dns[-50])
            law = pulsemap.dressed(R, mu=mu, eps=eps).law
            coef = coefficients(law)

            def first(A):
                return -sum(k1 * x for k1, x in zip(coef.k1, coef.xs(A)))

            def with_next(A):
                return coef.rate(A) - sum(
                    k1 * x * g * (abs(x) ** p) for k1, x, g, p in zip(coef.k1, coef.xs(A), coef.next_coef, coef.next_power))

            A = P / S0
            row = {name: nearest(roots(f), A) * S0 for name, f in
                   (("first", first), ("dressed", coef.rate), ("+next", with_next))}
            estimate = printed[-1] if printed and res["peaks"]["dressed-law"][-1] is not None else math.nan
            line = f"  {eps:<8g} {P:.6f} ({drift:.0e})"
            for name in ("first", "dressed", "+next"):
                e = 100 * (row[name] / P - 1)
                errs[name].append(abs(e))
                line += f"  {row[name]:.5f} {e:+6.2f}"
            line += f"   {coef.rate(A):+.2e}  {100 * estimate:.3g}"
            print(line)
        for name, e in errs.items():
            orders = [math.log2(a / b) for a, b in zip(e, e[1:])]
            print(f"  order of the {name} error per halving of eps: " + ", ".join(f"{o:.2f}" for o in orders))


if __name__ == "__main__":
    main()
