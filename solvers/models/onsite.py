"""The on-site force eps_i R_i(x_i, v_i) of Eq. 1 from a generated force module, as every DNS takes it.

One builder for the scenes' DNS (studies/points.py) and the relaxed model's segment runs: the
Python callables with their Jacobian diagonals and ``restrict`` for a moving window, the
stiffness hint method 'auto' reads, and the same force as data for the compiled engine (a
monomial table, else a generated numba force, else the reason the scipy engine runs it).
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from pulsemap.solvers.chain.equations import OnSiteForce
from pulsemap.solvers.chain.force_table import jit_force, table_from_module


class ForceError(ValueError):
    """An on-site force that cannot be evaluated at rest (or is not finite there)."""


def onsite_force(module, beads: int, first_perturbed: int, eps, values: Mapping[str, object]) -> OnSiteForce:
    """eps_i R_i on beads 1..beads (zero before first_perturbed); ``eps`` a scalar or per-bead array,
    ``values`` maps the module's parameters to scalars or per-bead arrays. ForceError when R is not
    finite at rest."""
    beads = int(beads)
    idx = np.arange(1, beads + 1, dtype=float)
    e = np.where(idx >= int(first_perturbed), np.asarray(eps, float) if np.ndim(eps) else float(eps), 0.0)
    full = tuple(np.asarray(values[name], float) if np.ndim(values[name]) else float(values[name])
                 for name in module.PARAMS)
    zeros = np.zeros(beads)
    try:
        with np.errstate(all="ignore"):
            kx = np.abs(np.asarray(module.force_dx(zeros, zeros, idx, e, *full), dtype=float))
            kv = np.abs(np.asarray(module.force_dv(zeros, zeros, idx, e, *full), dtype=float))
    except (ValueError, ZeroDivisionError, FloatingPointError) as exc:
        raise ForceError(f"the on-site force cannot be evaluated at rest: {exc}") from None
    if not (np.all(np.isfinite(kx)) and np.all(np.isfinite(kv))):
        raise ForceError("the on-site force is undefined at rest (non-finite value): check R and its parameters")
    hint = float(max(kv.max(initial=0.0), math.sqrt(kx.max(initial=0.0))))

    def build(lo: int, hi: int, monomials=None, jit=None) -> OnSiteForce:
        i, ei = idx[lo:hi], e[lo:hi]
        args = tuple(a[lo:hi] if np.ndim(a) else a for a in full)
        return OnSiteForce(
            force=lambda x, v: module.force(x, v, i, ei, *args),
            dforce_dx=lambda x, v: module.force_dx(x, v, i, ei, *args),
            dforce_dv=lambda x, v: module.force_dv(x, v, i, ei, *args),
            stiffness_hint=hint,
            restrict=build,
            monomials=monomials,
            jit=jit,
        )

    table = table_from_module(module, idx, e, full)  # the table: the compiled engine's F
    return build(0, beads, table, None if table is not None else (lambda: numba_force(module, idx, e, full)))


def numba_force(module, idx: np.ndarray, eps: np.ndarray, full: tuple):
    """The force module's R as a generated numba force for the compiled engine (chain/force_table.JitForce),
    or a string saying why the scipy engine integrates it instead."""
    from pulsemap.solvers.models.codeload import jit_force_module

    if hasattr(module, "DELTA"):
        return "non-smooth R (sign, Heaviside or abs, integrated as a stiff ramp): the scipy engine runs it"
    zeros = np.zeros(idx.shape)
    with np.errstate(all="ignore"):
        if np.any(np.asarray(module.force(zeros, zeros, idx, eps, *full)) != 0.0):
            return "R(0, 0) != 0 on some bead: the chain does not start at rest"
    try:
        return jit_force(jit_force_module(module.SOURCE["R"], module.SOURCE["params"]), idx, eps, full)
    except (ValueError, RuntimeError, ImportError) as exc:  # ImportError: a numba cache that cannot be loaded
        return f"R has no compiled form ({type(exc).__name__}: {exc})"
