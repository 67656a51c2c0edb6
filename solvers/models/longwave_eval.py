"""The long-wave amplitude law (Eq. 30) evaluated along the chain.

A single power of B has a closed form (generated ``longwave_law``); several powers are solved as
the ODE dB/di = rhs(B) (equivalent to the quadrature of Eq. 31a) with scipy, with events for
extinction (B -> 0) and blow-up. Contacts past the end of the law carry no value (None), and
the result says where and why the law ended, never a NaN.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import ModuleType
from typing import Callable

import numpy as np

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.models.map_iteration import contact_params


class LongwaveEvalError(PulsemapError):
    """The long-wave law cannot be evaluated for this scene."""


@dataclass(frozen=True)
class LawRun:
    contacts: np.ndarray
    A: list  # float, or None past the law's end
    peaks: list
    kind: str  # "power law", "exponential", "quadrature", "constant" (R does not force the contact)
    ended_at: float | None  # continuous contact index where A reached 0 or infinity
    ended: str  # "", "extinction", "blow-up"


def evaluate_law(module: ModuleType, A0: float, i0: float, contacts, eps: float, params) -> LawRun:
    """A(i) of Eq. 30 at ``contacts`` from A(i0) = A0."""
    if not getattr(module, "UNIFORM", False):
        raise LongwaveEvalError(
            "the long-wave law (Eq. 30) needs a uniform perturbation: drop 'longwave' from the methods"
        )
    contacts = np.asarray(contacts, dtype=float)
    if module.LAW_KIND is None:  # uniform, and no term of R forces contact i (e.g. R = 0): dB/di = 0
        return LawRun(contacts.astype(int), [float(A0)] * contacts.size, [float(A0) * module.S0] * contacts.size,
                      "constant", None, "")
    args = contact_params(module, params, int(i0) + 1)
    S0 = module.S0
    if hasattr(module, "longwave_law"):
        with np.errstate(over="ignore"):  # A past float64 is a blow-up, reported as such below
            A, base = module.longwave_law(contacts, A0, i0, eps, *args)
        A, base = np.broadcast_to(A, contacts.shape), np.broadcast_to(base, contacts.shape)
        ok = (base > 0) & np.isfinite(A)
        ended_at, ended = None, ""
        if np.all(base > 0) and not ok.all():  # the law's power left float64: blow-up at the first such contact
            ended_at, ended = float(contacts[np.argmin(ok)]), "blow-up"
        elif not ok.all():
            # base is linear in i: find where it crosses zero
            b0 = float(module.longwave_law(np.array([i0]), A0, i0, eps, *args)[1][0])
            b1 = float(module.longwave_law(np.array([i0 + 1.0]), A0, i0, eps, *args)[1][0])
            ended_at = i0 + b0 / (b0 - b1)
            # before the end the law is monotone: falling towards it is extinction, rising blow-up
            mid = float(module.longwave_law(np.array([(i0 + ended_at) / 2]), A0, i0, eps, *args)[0][0])
            ended = "extinction" if mid < A0 else "blow-up"
        vals = [float(a) if good else None for a, good in zip(A, ok)]
        return LawRun(contacts.astype(int), vals, [v * S0 if v is not None else None for v in vals],
                      module.LAW_KIND, ended_at, ended)
    # several powers: integrate dB/di
    P = module.P
    sol, ended_at, ended = integrate_law(lambda B: module.longwave_rhs(B, eps, *args), A0**P, i0, contacts)
    vals = law_values(sol, contacts, P)
    return LawRun(contacts.astype(int), vals, [v * S0 if v is not None else None for v in vals],
                  "quadrature", ended_at, ended)


def integrate_law(rhs: Callable[[float], float], B0: float, i0: float, contacts: np.ndarray):
    """Solve dB/di = rhs(B) (B clipped at 0) from B(i0) = B0 past the last contact with LSODA (the
    quadrature of Eq. 31a, or of a balance law), stopping where B falls to 1e-12 B0 or grows to 1e12 B0.

    Returns (solution, ended_at, ended): where the law ended (None if it did not) and how
    ("extinction", "blow-up" or "").
    """

    def die(i, y):
        return y[0] - 1e-12 * B0

    def blow(i, y):
        return y[0] - 1e12 * B0

    die.terminal = blow.terminal = True
    end = float(contacts.max()) if contacts.size else i0
    from scipy.integrate import solve_ivp  # scipy loads only when a law is evaluated

    sol = solve_ivp(lambda i, y: [rhs(max(y[0], 0.0))], (i0, max(end, i0 + 1e-9)), [B0], method="LSODA",
                    rtol=1e-11, atol=1e-14 * B0, dense_output=True, events=(die, blow))
    ended_at, ended = None, ""
    if sol.status == 1:
        ended_at = float(sol.t[-1])
        ended = "extinction" if sol.t_events[0].size else "blow-up"
    return sol, ended_at, ended


def law_values(sol, contacts: np.ndarray, power: float) -> list:
    """A = B^(1/power) of ``integrate_law``'s solution at each contact; None past where it stopped."""
    stop = float(sol.t[-1])
    return [max(float(sol.sol(c)[0]), 0.0) ** (1.0 / power) if c <= stop + 1e-12 else None for c in contacts]
