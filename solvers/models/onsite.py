"""The on-site force eps_i R_i(x_i, v_i) of Eq. 1 from a generated force module, as every DNS takes it.

One builder (models/chain_build.py builds every DNS chain with it; the relaxed model reads coefficients): the
Python callables with their Jacobian diagonals and ``restrict`` for a moving window, the
stiffness hint method 'auto' reads, and the same force as data for the compiled engine (a
monomial table, else a generated numba force, else the reason the scipy engine runs it).

Per-bead data stays O(window) when R is uniform (no i, scalar eps and parameters): every bead from
first_perturbed on then has the same force, so tables and checks are built on beads
1..first_perturbed and the moving window slices its own beads.
"""

from __future__ import annotations

import math
import re
from functools import cached_property
from typing import Mapping

import numpy as np

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.chain.equations import OnSiteForce, check_finite
from pulsemap.solvers.chain.force_table import jit_force, table_from_module

__all__ = ["ForceError", "distinct_beads", "numba_force", "onsite_force"]


class ForceError(PulsemapError):
    """An on-site force that cannot be evaluated at rest (or is not finite there)."""


class _Beads:
    """Bead indices i and eps_i of beads lo..hi-1 (0-based), made when first read."""

    def __init__(self, lo: int, hi: int, first_perturbed: int, eps) -> None:
        self.lo, self.hi, self.first_perturbed, self.eps_value = lo, hi, first_perturbed, eps

    @cached_property
    def i(self) -> np.ndarray:
        return np.arange(self.lo + 1, self.hi + 1, dtype=float)

    @cached_property
    def eps(self) -> np.ndarray:
        e = self.eps_value[self.lo:self.hi] if np.ndim(self.eps_value) else self.eps_value
        return np.where(self.i >= self.first_perturbed, e, 0.0)


def distinct_beads(module, beads: int, first_perturbed: int, eps, values: Mapping[str, object]) -> int:
    """How many leading beads carry every distinct value of the force: first_perturbed when R is
    uniform (no i in R, scalar eps and parameters: beads past it repeat it), else the whole chain."""
    uses_i = "i" in re.findall(r"[A-Za-z_][A-Za-z0-9_]*", str(module.SOURCE["R"]))
    if uses_i or np.ndim(eps) or any(np.ndim(values[name]) for name in module.PARAMS):
        return beads
    return min(beads, first_perturbed)


def onsite_force(module, beads: int, first_perturbed: int, eps, values: Mapping[str, object]) -> OnSiteForce:
    """eps_i R_i on beads 1..beads (zero before first_perturbed); ``eps`` a scalar or per-bead array,
    ``values`` maps the module's parameters to scalars or per-bead arrays. ``restrict(lo, hi)`` gives
    the same force on beads lo..hi-1; ``monomials`` is the force as a table for the compiled engine.
    ForceError when R is not finite at rest."""
    beads, fp = int(beads), int(first_perturbed)
    eps = np.asarray(eps, float) if np.ndim(eps) else float(eps)
    full = tuple(np.asarray(values[name], float) if np.ndim(values[name]) else float(values[name])
                 for name in module.PARAMS)
    head = _Beads(0, distinct_beads(module, beads, fp, eps, values), fp, eps)  # every distinct bead
    idx, e = head.i, head.eps
    args0 = tuple(a[: idx.size] if np.ndim(a) else a for a in full)
    zeros = np.zeros(idx.size)
    try:
        with np.errstate(all="ignore"):
            kx = np.abs(np.asarray(module.force_dx(zeros, zeros, idx, e, *args0), dtype=float))
            kv = np.abs(np.asarray(module.force_dv(zeros, zeros, idx, e, *args0), dtype=float))
    except (ValueError, ZeroDivisionError, FloatingPointError) as exc:
        raise ForceError(f"the on-site force cannot be evaluated at rest: {exc}") from None
    if not (np.all(np.isfinite(kx)) and np.all(np.isfinite(kv))):
        raise ForceError("the on-site force is undefined at rest (non-finite value): check R and its parameters")
    hint = float(max(kv.max(initial=0.0), math.sqrt(kx.max(initial=0.0))))

    def build(lo: int, hi: int, monomials=None, jit=None) -> OnSiteForce:
        b = _Beads(lo, hi, fp, eps)
        args = tuple(a[lo:hi] if np.ndim(a) else a for a in full)
        skip = min(max(fp - 1 - lo, 0), hi - lo)  # the leading beads with eps_i = 0: R is not evaluated there
        return OnSiteForce(
            force=_checked(module.force, b, args, skip, "force"),
            dforce_dx=_checked(module.force_dx, b, args, skip, "slope dF/du"),
            dforce_dv=_checked(module.force_dv, b, args, skip, "slope dF/dv"),
            stiffness_hint=hint,
            restrict=build,
            monomials=monomials,
            jit=jit,
            ramp=float(getattr(module, "DELTA", 0.0)),
        )

    table = table_from_module(module, idx, e, args0)  # the table: the compiled engine's F
    return build(0, beads, table, None if table is not None else _once(lambda: numba_force(module, idx, e, args0)))


def _checked(fn, b: _Beads, args: tuple, skip: int, what: str):
    """``fn`` of the generated force module as F(x, v) on beads b.lo+1..b.hi: the first ``skip`` beads
    (unperturbed) get 0.0 without a call (a slice, cheaper than the module's own mask); ForceNotFinite
    at the first bead where the value is not finite (the DNS runs under np.errstate(all="ignore"):
    solvers/chain/dns.py)."""
    tail = tuple(a[skip:] if np.ndim(a) else a for a in args)

    def force(x, v):
        if skip:  # b.i and b.eps are made at the first call (a million-bead chain builds no array at once)
            out = np.zeros(np.shape(x))
            out[skip:] = fn(x[skip:], v[skip:], b.i[skip:], b.eps[skip:], *tail)
        else:
            out = fn(x, v, b.i, b.eps, *args)
        if not math.isfinite(out.dot(out)):  # the cheapest test (an array: the module adds 0.0 * x); inf past 1e154
            check_finite(out, x, v, b.lo, what)
        return out

    return force


def _once(make):
    """``make`` called the first time only (a built numba force is kept with its OnSiteForce)."""
    made: list = []

    def get():
        if not made:
            made.append(make())
        return made[0]

    return get


def numba_force(module, idx: np.ndarray, eps: np.ndarray, full: tuple):
    """The force module's R as a generated numba force for the compiled engine (chain/force_table.JitForce),
    or a string saying why the scipy engine integrates it instead."""
    from pulsemap.solvers.models.codeload import jit_force_module

    zeros = np.zeros(idx.shape)
    with np.errstate(all="ignore"):
        if np.any(np.asarray(module.force(zeros, zeros, idx, eps, *full)) != 0.0):
            return "R(0, 0) != 0 on some bead: the chain does not start at rest"
    try:
        return jit_force(jit_force_module(module.SOURCE["R"], module.SOURCE["params"]), idx, eps, full)
    except (ValueError, RuntimeError, ImportError) as exc:  # ImportError: a numba cache that cannot be loaded
        return f"R has no compiled form ({type(exc).__name__}: {exc})"
