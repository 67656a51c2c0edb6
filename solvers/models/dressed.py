"""The dressed (second-order) law evaluated along the chain (derive/dressed.py; sympy-free); its coefficients are
derived in models/dressed_expansion.py or calibrated in studies/dressed_calibration.py.

    d ln A/di = -sum_j k1_j x_j / (1 - rho_j x_j) - sum_{j<l} k2_jl x_j x_l,   x_j = c_j A^e_j

from ln A(i0) = ln A0 + sum_j Delta_j k1_j x_j(A0)/(1 - rho_j x_j(A0)) (the onset lag), solved with
LSODA (rtol 1e-11). It stops where A falls to 1e-12 A0 (extinction), grows to 1e12 A0, or some
|rho_j x_j| reaches 0.95 (the second-order term as large as the first: the series, and its Pade
form, have lost their meaning; a restoring foundation near extinction, x = c A^(-1/2)): contacts
past the end carry None. ``beyond`` is the first contact index where some |x_j| exceeds its (calibrated)
validity bound: a warning, not a cut. Each value carries an estimate of its relative error, measured on the
law's own short DNS segments (``MeasuredError``, studies/run/dressed.py) and carried along the chain by the
law's own sensitivity (``error_bound``); where it passes ACCURACY the law gives no value (status "beyond its
accuracy"): the validity cut is the estimate's.
Measured on Van der Pol, the law's stationary-peak error is O(eps^(3/2)) (docs/models.rst).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.models.balance_eval import BalanceRun

POLE_MARGIN = 0.05
ACCURACY = 0.05  # the law gives no value where its estimated error passes 5 %
ERROR_STEP = 0.125  # the carried error's step in contacts (its coefficients change over many contacts)


class DressedEvalError(PulsemapError):
    """The dressed law cannot be evaluated as asked."""


@dataclass(frozen=True)
class DressedCoefficients:
    """Plain numbers of one dressed law: per monomial (c, e, k1, rho, lag, x_bound, (a, b)), cross (j, l, k2), and per
    monomial the first neglected term of delta/(k1 x), g |x|^p (next_coef g, next_power p: 1.5 or 2)."""

    c: tuple[float, ...]
    e: tuple[float, ...]
    k1: tuple[float, ...]
    rho: tuple[float, ...]
    lag: tuple[float, ...]
    x_bound: tuple[float, ...]
    cross: tuple[tuple[int, int, float], ...] = ()
    c_of_i: tuple | None = None  # site-dependent R: c_j(i) as functions of the contact index (else c)
    next_coef: tuple[float, ...] = ()  # empty: no neglected term known
    next_power: tuple[float, ...] = ()
    monomials: tuple[tuple[int, int], ...] = ()  # (a, b) of each u^a v^b (a launched segment's force)

    def xs(self, A: float, i: float = 0.0) -> list[float]:
        cs = self.c if self.c_of_i is None else [f(i) for f in self.c_of_i]
        return [c * A**e for c, e in zip(cs, self.e)]

    def rate(self, A: float, i: float = 0.0) -> float:
        xs = self.xs(A, i)
        total = -sum(k1 * x / (1.0 - r * x) for k1, r, x in zip(self.k1, self.rho, xs))
        return total - sum(k2 * xs[j] * xs[l] for j, l, k2 in self.cross)

    def slope(self, A: float, i: float = 0.0) -> float:
        """d(rate)/d ln A: how an error in ln A grows (> 0) or relaxes (< 0) along the chain."""
        xs = self.xs(A, i)
        total = -sum(k1 * e * x / (1.0 - r * x) ** 2 for k1, e, r, x in zip(self.k1, self.e, self.rho, xs))
        return total - sum(k2 * (self.e[j] + self.e[l]) * xs[j] * xs[l] for j, l, k2 in self.cross)

    def shift(self, A0: float, i0: float = 0.0) -> float:
        xs = self.xs(A0, i0)
        return sum(d * k1 * x / (1.0 - r * x) for d, k1, r, x in zip(self.lag, self.k1, self.rho, xs))


@dataclass(frozen=True)
class MeasuredError:
    """What the law's own short DNS segments measured (studies/run/dressed.py, ``measure_law_error``).

    ``contacts``/``lnA``: ln A of the scene's own chain (kicked, cut short after the last of ``contacts``) at
    contacts i0 + 1 .. iL: there the law's error is measured, to the DNS's stated peak accuracy ``tol`` (the
    looser of its rtol and the moving window's 1e-8: the accuracy of any DNS it is compared with).
    ``nodes_lnA``/``residual``: bounds on |true rate - law rate| per contact at amplitudes along the law's path,
    each read on an exact wave launched into a uniform chain carrying the coefficients there, after its own onset
    has relaxed, at the ln A where it was read (inf: the launched pulse was lost; the chain's pulse died within
    the seed segment). ``offset``: |kicked - launched| rate residual at iL (the kicked pulse is not an exact
    wave), carried along with the residuals. No ``contacts``: nothing could be measured (no value is given)."""

    contacts: tuple[float, ...]
    lnA: tuple[float, ...]
    tol: float
    nodes_lnA: tuple[float, ...]
    residual: tuple[float, ...]
    offset: float

    def residual_bound(self, lo: float, hi: float | None = None) -> float:
        """The largest |residual| of the nodes in [lo, hi] of ln A and of the two around it (the nearest one
        outside their range); inf without nodes (nothing was read)."""
        if not len(self.nodes_lnA):
            return math.inf
        order = np.argsort(self.nodes_lnA)
        x, r = np.asarray(self.nodes_lnA)[order], np.abs(np.asarray(self.residual))[order]
        k0 = max(int(np.searchsorted(x, lo)) - 1, 0)
        k1 = min(int(np.searchsorted(x, lo if hi is None else hi)), r.size - 1)
        return float(r[k0:k1 + 1].max())


@dataclass(frozen=True)
class DressedRun:
    """The dressed law along the chain: the amplitudes (``run``), the first index past the validity bound
    (``beyond``, a warning only) and per contact the estimated relative error of A (``accuracy``, None where
    no value or no measurement)."""

    run: BalanceRun
    beyond: float | None
    accuracy: list


def error_bound(coef: DressedCoefficients, sol, measured: MeasuredError, contacts: np.ndarray,
                given: Sequence[bool]) -> list:
    """Per contact the bound on |ln A_law - ln A_true|: measured on the seed segment (plus its accuracy ``tol``);
    past it, from the seed segment's last error, dD/di = sigma D + residual_bound(ln A -+ D) + offset, sigma the
    larger secant slope of the rate over ln A -+ D: the measured rate residuals carried along the chain by the
    law's own sensitivity, where the true path may be (a bound on e' = rate(lnA + e) - rate(lnA) + r(lnA + e)).
    None where no value."""
    if not measured.contacts:  # nothing was measured: no value has an estimate
        return [math.inf if ok else None for ok in given]
    seed = dict(zip((int(c) for c in measured.contacts), measured.lnA))
    iL = max(measured.contacts)
    D_L = abs(float(sol.sol(iL)[0]) - seed[int(iL)]) + measured.tol
    later = [c for c, ok in zip(contacts, given) if ok and c > iL]
    carried, D, i = {}, D_L, float(iL)
    for c in later:  # exact over each eighth of a contact with the coefficients at its mid-point
        while i < c - 1e-12:
            h = min(ERROR_STEP, c - i)
            mid = i + h / 2
            lnA = float(sol.sol(mid)[0])
            try:  # past float64 or the law's pole the bound has lost its meaning: inf
                sigma = h * (coef.slope(math.exp(lnA), mid) if D == 0 else
                             max(coef.rate(math.exp(lnA + D), mid) - coef.rate(math.exp(lnA), mid),
                                 coef.rate(math.exp(lnA), mid) - coef.rate(math.exp(lnA - D), mid)) / D)
                q = (measured.residual_bound(lnA - D, lnA + D) + measured.offset) * h
                D = D * math.exp(sigma) + (q * math.expm1(sigma) / sigma if abs(sigma) > 1e-12 else q)
            except (OverflowError, ZeroDivisionError):
                D = math.inf
            if not math.isfinite(D):
                D = math.inf
                break
            i += h
        carried[c] = D
        if D == math.inf:
            break
    out = []
    for c, ok in zip(contacts, given):
        if not ok:
            out.append(None)
        elif c <= iL:
            out.append(abs(float(sol.sol(c)[0]) - seed[int(c)]) + measured.tol if int(c) in seed else None)
        else:
            out.append(float(carried.get(c, math.inf)))
    return out


def evaluate_dressed_law(coef: DressedCoefficients, S0: float, A0: float, i0: float, contacts: Sequence[float],
                         measured: MeasuredError | None = None) -> DressedRun:
    """A(i) of the dressed law at ``contacts`` from the seed A(i0) = A0. With ``measured`` each value carries its
    estimated relative error exp(D) - 1 (``error_bound``) and none is given where that passes ACCURACY (the
    validity cut); without, every value to the law's end is given, with no estimate."""
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
        return DressedRun(run, float(i0), vals)
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
    stop = float(sol.t[-1])
    given = [c <= stop + 1e-12 for c in contacts]
    lnAs = [float(sol.sol(c)[0]) if ok else None for c, ok in zip(contacts, given)]
    if measured is None:
        errs = [None] * len(contacts)
    else:
        errs = [math.expm1(D) if D is not None else None for D in error_bound(coef, sol, measured, contacts, given)]
    quiet = [k for k, e in enumerate(errs) if e is not None and not e <= ACCURACY]  # indices into contacts
    vals = [math.exp(y) if y is not None and k not in quiet else None for k, y in enumerate(lnAs)]
    accuracy = [e if v is not None else None for e, v in zip(errs, vals)]
    msg = f"{status} at contact index {ended_at:.6g}" if ended_at is not None else "ODE solved (LSODA, rtol 1e-11)"
    if quiet:
        k = max(quiet, key=errs.__getitem__)
        worst, first_quiet, last_quiet = contacts[k], contacts[quiet[0]], contacts[quiet[-1]]
        where = (f"contact {first_quiet:g}" if len(quiet) == 1
                 else f"{len(quiet)} contacts from {first_quiet:g} to {last_quiet:g}")
        msg = (f"beyond its accuracy at {where}: its estimated error (measured rate residuals carried along the "
               f"chain) passes {100 * ACCURACY:g} % (up to {100 * errs[k]:.3g} % at contact {worst:g}); no values "
               "there" + ("" if status == "ok" else f"; then {msg}"))
        status = "beyond its accuracy" if status == "ok" else status
    run = BalanceRun("dressed", "law", contacts.astype(int), vals, [v * S0 if v is not None else None for v in vals],
                     status, msg, ended_at, "dressed (second order)", "exact")
    return DressedRun(run, beyond, accuracy)
