"""Energy- and momentum-balance models evaluated along the chain (sympy-free; derive/balance.py).

Map: K A_i^Q = K A_{i-1}^Q + rate(A_{i-1}) with bead i's parameters (generated ``balance_step``);
the pulse dies where the right-hand side reaches zero (all the wave's energy or momentum spent),
or where A falls below ``death_fraction`` of its seed. Law: K dB/di = eps sum C_p B^p, B = A^Q,
in closed form for one power (generated ``law_closed``), else solved as an ODE (longwave_eval.py:
``solve_law``, scipy only where the law ends). Contacts past a model's end carry None, never a NaN.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import ModuleType
from typing import Mapping

import numpy as np

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.models.longwave_eval import solve_law
from pulsemap.solvers.models.map_iteration import check_seed, contact_params


class BalanceEvalError(PulsemapError):
    """A balance model that cannot be evaluated as asked."""


@dataclass(frozen=True)
class BalanceRun:
    """Amplitudes (and peaks A S(0), Eq. 32) of one balance model along the chain."""

    model: str  # "energy" or "momentum"
    form: str  # "map" or "law"
    contacts: np.ndarray
    A: list  # float, or None past the model's end
    peaks: list
    status: str  # "ok", "died", "blow-up" (map), "extinction", "blow-up" (law)
    message: str
    ended_at: float | None  # contact (index) where the model ended
    law_kind: str  # "map", "power law", "exponential", "quadrature"
    profile: str


def iterate_balance_map(
    module: ModuleType,
    seed_A: float,
    seed_contact: int,
    last_contact: int,
    eps: float,
    params: Mapping[str, object],
    death_fraction: float = 1e-6,
) -> BalanceRun:
    """K A_i^Q = K A_{i-1}^Q + rate(A_{i-1}) (bead i) from A_{seed_contact} = seed_A to ``last_contact``."""
    check_seed(seed_A, BalanceEvalError, seed_contact=seed_contact, last_contact=last_contact)
    contacts = np.arange(seed_contact + 1, last_contact + 1)
    amps: list = []
    a = float(seed_A)
    status, message, ended = "ok", f"reached contact {last_contact}", None
    for i in contacts:
        args = contact_params(module, params, int(i))
        try:
            with np.errstate(all="ignore"):
                new, base = module.balance_step(a, eps, *args)
            new, base = float(new), float(base)
        except OverflowError:  # a power of a Python float past float64 (numpy's give inf instead)
            new = base = math.inf
        if base == math.inf or new == math.inf:
            status, ended = "blow-up", int(i)
            message = (f"the {module.MODEL} map blows up at contact {i}: from A_{i - 1} = {a:.4g} the wave's "
                       f"{module.MODEL} K A^Q plus bead {i}'s {'work' if module.MODEL == 'energy' else 'impulse'} "
                       "is past float64's range")
            break
        if not math.isfinite(base) or not math.isfinite(new) or base <= 0:
            status, ended = "died", int(i)
            message = f"pulse died at contact {i}: the work/impulse of bead {i} exceeds what the wave carries"
            break
        if new < death_fraction * seed_A:
            status, ended = "died", int(i)
            message = f"pulse died at contact {i}: A fell below {death_fraction:g} of its seed"
            break
        amps.append(new)
        a = new
    vals = amps + [None] * (len(contacts) - len(amps))
    return BalanceRun(module.MODEL, "map", contacts, vals, [v * module.S0 if v is not None else None for v in vals],
                      status, message, ended, "map", module.SOURCE["profile"])


def evaluate_balance_law(module: ModuleType, A0: float, i0: float, contacts, eps: float, params) -> BalanceRun:
    """A(i) from K dB/di = eps sum C_p B^p, B = A^Q, at ``contacts`` from A(i0) = A0."""
    check_seed(A0, BalanceEvalError)
    if not getattr(module, "UNIFORM", False):
        raise BalanceEvalError(
            f"the {module.MODEL}-balance law needs a uniform perturbation: use the {module.MODEL}-balance map"
        )
    contacts = np.asarray(contacts, dtype=float)
    args = contact_params(module, params, int(i0) + 1)
    S0, Q = module.S0, module.Q
    if module.LAW_KIND is None:  # uniform, and R does no work / gives no impulse (e.g. R = 0): dB/di = 0
        vals = [float(A0)] * contacts.size
        return BalanceRun(module.MODEL, "law", contacts.astype(int), vals, [v * S0 for v in vals], "ok",
                          "constant: R does not change the wave's " + module.MODEL, None, "constant",
                          module.SOURCE["profile"])
    if hasattr(module, "law_closed"):
        with np.errstate(all="ignore"):
            A, base = module.law_closed(contacts, A0, i0, eps, *args)
        A, base = np.broadcast_to(A, contacts.shape), np.broadcast_to(base, contacts.shape)
        ok = (base > 0) & np.isfinite(A)
        ended_at, status = None, "ok"
        if module.LAW_KIND == "power law":
            with np.errstate(all="ignore"):  # only the base (linear in i) is read: its power may overflow
                b0 = float(module.law_closed(np.array([i0]), A0, i0, eps, *args)[1][0])
                b1 = float(module.law_closed(np.array([i0 + 1.0]), A0, i0, eps, *args)[1][0])
            if b1 < b0:  # base is linear in i and falls: the law ends where it reaches zero
                ended_at = i0 + b0 / (b0 - b1)
                status = "extinction" if module.LAW_POWER < 1 else "blow-up"
        vals = [float(a) if good else None for a, good in zip(A, ok)]
        msg = f"{status} at contact index {ended_at:.6g}" if ended_at is not None else "closed form"
        return BalanceRun(module.MODEL, "law", contacts.astype(int), vals,
                          [v * S0 if v is not None else None for v in vals],
                          status if ended_at is not None and ended_at <= contacts.max(initial=i0) else "ok",
                          msg, ended_at, module.LAW_KIND, module.SOURCE["profile"])
    law = solve_law(lambda B: module.law_rhs(B, eps, *args), A0, i0, contacts, Q)
    if law.failure is not None:
        raise BalanceEvalError(f"the {module.MODEL}-balance law could not be integrated: {law.failure}")
    status, vals, ended_at = law.ended or "ok", law.A, law.ended_at
    msg = f"{status} at contact index {ended_at:.6g}" if ended_at is not None else f"ODE solved ({law.solver})"
    return BalanceRun(module.MODEL, "law", contacts.astype(int), vals, [v * S0 if v is not None else None for v in vals],
                      status, msg, ended_at, "quadrature", module.SOURCE["profile"])
