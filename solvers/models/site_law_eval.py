"""Laws for a site-dependent R evaluated along the chain: K dB/di = eps sum_p C_p(i) B^p.

derive/site_law.py forms these laws (closed form when C_p(i) integrates); here they are solved
as ODEs in the contact index with the generated per-bead functions, so no sympy runs per call:

* energy / momentum law: dB/di = balance_rate(A, params of bead i + 1/2) / K  (the balance map's
  step from contact i-1 to i is bead i's work, centred at i - 1/2);
* long-wave law (Eq. 30): dB/di = F1(A, A, A; params of beads i, i+1) / (f1 - f3), the first map
  equation at equal amplitudes (its contact terms cancel: f1 - 2 f2 + f3 = 0).

A parameter given as an expression of i is evaluated at the continuous position; per-bead lists
and draws are piecewise constant (derive.perturbation.Perturbation.values_at).
"""

from __future__ import annotations

from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.models.amplitude_ode import integrate_amplitude_law
from pulsemap.solvers.models.longwave_eval import LawRun

if TYPE_CHECKING:  # pragma: no cover  (sympy-free at import time)
    from pulsemap.symbolic.perturbation import Perturbation

#: Bead position of a balance law's work at contact index i (derive/site_law.py BEAD_SHIFT).
BALANCE_SHIFT = 0.5


class SiteLawError(PulsemapError):
    """A site-dependent law that cannot be evaluated as asked."""


def _arg_values(module: ModuleType, pert: Perturbation, position: float, shift: float) -> list[float]:
    """The generated functions' parameter arguments at contact index ``position``."""
    out = []
    for base, off in module.ARGS:  # (parameter, bead offset); ("i", 0) is the bead index
        if base == "i":
            out.append(position + shift)
        else:
            out.append(float(pert.values_at(base, [position + shift + off])[0]))
    return out


def _real(value, position: float, pert: Perturbation) -> float:
    """``value`` as a float; a complex value (R between beads) is a SiteLawError naming where and why."""
    if isinstance(value, complex) or np.iscomplexobj(value):
        raise SiteLawError(
            f"R = {pert.text} is complex at contact index {position:.6g} ({complex(value):.3g}): the law evaluates "
            "R between beads (non-integer i), where a power of a negative number such as (-1)^i is not real; "
            "write it as cos(pi*i), equal at every bead and real in between"
        )
    return float(value)


def rate_function(module: ModuleType, pert: Perturbation, kind: str):
    """dB/di as a function (i, B) for ``kind`` "balance" (a balance module) or "longwave" (a map module)."""
    eps = float(pert.eps)
    if kind == "balance":
        K, Q = float(module.K), float(module.Q)

        def rhs(i: float, B: float) -> float:
            A = max(B, 0.0) ** (1.0 / Q)
            return _real(module.balance_rate(A, eps, *_arg_values(module, pert, i, BALANCE_SHIFT)), i, pert) / K

        return rhs, Q
    if kind == "longwave":
        f13, P = float(module.f1) - float(module.f3), float(module.P)

        def rhs(i: float, B: float) -> float:
            A = max(B, 0.0) ** (1.0 / P)
            amps = (A, A) if module.VARIANT == "1d" else (A, A, A)
            return _real(module.map_residual(*amps, eps, *_arg_values(module, pert, i, 0.0))[0], i, pert) / f13

        return rhs, P
    raise SiteLawError(f"unknown law kind {kind!r}: 'balance' or 'longwave'")


def evaluate_site_law(module: ModuleType, pert: Perturbation, kind: str, A0: float, i0: float, contacts) -> LawRun:
    """A(i) of the site-dependent law from A(i0) = A0 at ``contacts`` (LSODA, rtol 1e-11), with
    events for extinction (B -> 1e-12 B0) and blow-up (B -> 1e12 B0); None past the law's end."""
    if not (np.isfinite(A0) and A0 > 0):
        raise SiteLawError(f"the initial amplitude must be a finite number > 0, got {A0!r}")
    rhs, Q = rate_function(module, pert, kind)
    contacts = np.asarray(contacts, dtype=float)
    vals, ended_at, ended = integrate_amplitude_law(rhs, A0, Q, i0, contacts, SiteLawError, "the site-dependent law")
    S0 = float(module.S0)
    return LawRun(contacts.astype(int), vals, [v * S0 if v is not None else None for v in vals],
                  "quadrature (site-dependent)", ended_at, ended)
