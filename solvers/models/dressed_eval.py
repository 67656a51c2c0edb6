"""The dressed (second-order) law evaluated along the chain (derive/dressed.py; sympy-free).

    d ln A/di = -sum_j k1_j x_j / (1 - rho_j x_j) - sum_{j<l} k2_jl x_j x_l,   x_j = c_j A^e_j

from ln A(i0) = ln A0 + sum_j Delta_j k1_j x_j(A0)/(1 - rho_j x_j(A0)) (the onset lag), solved with
LSODA (rtol 1e-11). It stops where A falls to 1e-12 A0 (extinction), grows to 1e12 A0, or some
|rho_j x_j| reaches 0.95 (the second-order term as large as the first: the series, and its Pade
form, have lost their meaning; a restoring foundation near extinction, x = c A^(-1/2)): contacts
past the end carry None. ``beyond`` is the first contact index where some |x_j| exceeds its validity bound;
the law gives no values past it either (status "beyond its validity bound"): it stays quiet where its
two-term form is not trusted.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from pulsemap.solvers.models.balance_eval import BalanceRun

POLE_MARGIN = 0.05


class DressedEvalError(ValueError):
    """The dressed law cannot be evaluated as asked."""


@dataclass(frozen=True)
class DressedCoefficients:
    """Plain numbers of one dressed law: per monomial (c, e, k1, rho, lag, x_bound), cross (j, l, k2)."""

    c: tuple[float, ...]
    e: tuple[float, ...]
    k1: tuple[float, ...]
    rho: tuple[float, ...]
    lag: tuple[float, ...]
    x_bound: tuple[float, ...]
    cross: tuple[tuple[int, int, float], ...] = ()
    c_of_i: tuple | None = None  # site-dependent R: c_j as functions of the contact index (else c)

    def xs(self, A: float, i: float = 0.0) -> list[float]:
        cs = self.c if self.c_of_i is None else [f(i) for f in self.c_of_i]
        return [c * A**e for c, e in zip(cs, self.e)]

    def rate(self, A: float, i: float = 0.0) -> float:
        xs = self.xs(A, i)
        total = -sum(k1 * x / (1.0 - r * x) for k1, r, x in zip(self.k1, self.rho, xs))
        return total - sum(k2 * xs[j] * xs[l] for j, l, k2 in self.cross)

    def shift(self, A0: float, i0: float = 0.0) -> float:
        xs = self.xs(A0, i0)
        return sum(d * k1 * x / (1.0 - r * x) for d, k1, r, x in zip(self.lag, self.k1, self.rho, xs))


def evaluate_dressed_law(coef: DressedCoefficients, S0: float, A0: float, i0: float,
                         contacts: Sequence[float]) -> tuple[BalanceRun, float | None]:
    """A(i) of the dressed law at ``contacts`` from the seed A(i0) = A0; also the first index where some
    |x_j| passes its validity bound (None if it never does before the law ends)."""
    if not (np.isfinite(A0) and A0 > 0):
        raise DressedEvalError(f"the initial amplitude must be a finite number > 0, got {A0!r}")
    contacts = np.asarray(contacts, dtype=float)
    lnA0 = math.log(A0) + coef.shift(A0, i0)

    def rhs(i, y):
        return [coef.rate(math.exp(y[0]), i)]

    def die(i, y):
        return y[0] - (math.log(A0) - 27.6)  # A = 1e-12 A0

    def blow(i, y):
        return y[0] - (math.log(A0) + 27.6)

    def pole(i, y):  # |rho x| -> 1: the second-order term as large as the first, the series has lost its meaning
        A = math.exp(y[0])
        return (1.0 - POLE_MARGIN) - max([abs(r * x) for r, x in zip(coef.rho, coef.xs(A, i))] + [0.0])

    def past_bound(i, y):
        A = math.exp(y[0])
        return max([abs(x) / b if b > 0 else 0.0 for x, b in zip(coef.xs(A, i), coef.x_bound)] + [0.0]) - 1.0

    die.terminal = blow.terminal = pole.terminal = True
    if pole(i0, [math.log(A0)]) <= 0:
        vals = [None] * len(contacts)
        run = BalanceRun("dressed", "law", contacts.astype(int), vals, vals, "outside its range",
                         f"outside its range at the seed: |(k2/k1) x| >= {1 - POLE_MARGIN:g} (the second-order term "
                         "as large as the first)", float(i0), "dressed (second order)", "exact")
        return run, float(i0)
    end = max(float(contacts.max(initial=i0)), i0 + 1e-9)
    from scipy.integrate import solve_ivp  # scipy loads only when a law is evaluated

    sol = solve_ivp(rhs, (i0, end), [lnA0], method="LSODA", rtol=1e-11, atol=1e-13, dense_output=True,
                    events=(die, blow, pole, past_bound))
    if sol.status < 0:
        raise DressedEvalError(f"the dressed law could not be integrated: {sol.message}")
    ended_at, status = None, "ok"
    if sol.status == 1:
        ended_at = float(sol.t[-1])
        status = ("extinction" if sol.t_events[0].size else "blow-up" if sol.t_events[1].size
                  else f"outside its range (|(k2/k1) x| reached {1 - POLE_MARGIN:g})")
    beyond = float(sol.t_events[3][0]) if sol.t_events[3].size else None
    if beyond is None and past_bound(i0, [lnA0]) > 0:
        beyond = float(i0)
    if beyond is not None and (ended_at is None or beyond < ended_at) and beyond < float(sol.t[-1]):
        ended_at, status = beyond, "beyond its validity bound"
    stop = float(sol.t[-1]) if ended_at is None else ended_at
    vals = [math.exp(float(sol.sol(c)[0])) if c <= stop + 1e-12 else None for c in contacts]
    msg = f"{status} at contact index {ended_at:.6g}" if ended_at is not None else "ODE solved (LSODA, rtol 1e-11)"
    if status == "beyond its validity bound":
        msg += ": some |x_j| passes the two-term law's validity bound (derive --model dressed prints it); no values past it"
    run = BalanceRun("dressed", "law", contacts.astype(int), vals, [v * S0 if v is not None else None for v in vals],
                     status, msg, ended_at, "dressed (second order)", "exact")
    return run, beyond
