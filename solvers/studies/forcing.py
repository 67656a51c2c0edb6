"""The on-site force eps_i R_i(x_i, v_i) of a scene for the DNS (paper Eq. 1), built in one place.

A scene's force goes one way down: its parameter values per bead (:func:`parameter_values`, or
:func:`bead_params` from a sweep's plain chain), the generated force module
(:mod:`~pulsemap.solvers.models.codeload`), then :func:`chain_force`, the OnSiteForce the DNS takes
with its monomial table or generated numba force (:mod:`~pulsemap.solvers.chain.force_table`).
:func:`make_force` keeps what it built for a scene in-process (keyed by the resolved force: R, eps,
parameter values, first_perturbed, beads, and where generated modules are read), so a second run of
a scene neither loads the generated module again nor rebuilds the table.

Per-bead data stays O(window) when R is uniform (no i, scalar parameters): every bead from
first_perturbed on then has the same force, so tables and checks are built on beads
1..first_perturbed and the moving window slices its own beads; a site-dependent R is O(beads) (its
values are data of the whole chain).
"""

from __future__ import annotations

import math
import re
from functools import cached_property
from typing import Any, Mapping

import numpy as np

from pulsemap.symbolic.cache import cache_root
from pulsemap.symbolic.param_forms import uniform_draw
from pulsemap.solvers.chain.dns import OnSiteForce
from pulsemap.solvers.chain.force_table import jit_force, table_from_module
from pulsemap.solvers.data.scene import Scene
from pulsemap.solvers.models import codeload
from pulsemap.solvers.models.codeload import force_module
from pulsemap.solvers.studies.methods import RunError
from pulsemap.solvers.studies.sweep import SweepError

__all__ = ["bead_params", "chain_force", "make_force", "parameter_values"]

#: Forces built by make_force in this process, by resolved force (most recent last).
_FORCES: dict[tuple, OnSiteForce] = {}
_FORCES_KEPT = 32


def parameter_values(scene: Scene, beads: int | None) -> dict:
    """Parameter values: scalars, or per-bead arrays. Without [chain] beads, a parameter given as an
    expression of i is evaluated on the chain the contacts need (as an R containing i is): only
    lists and random draws fix the chain length themselves (the scene file requires beads for them)."""
    pert = scene.perturbation
    out = {}
    if beads is None:
        from pulsemap.solvers.chain.equations import chain_length_for

        beads = chain_length_for(scene.contacts[1])
    for name in pert.used_parameters:
        if name not in pert.site_dependent:
            out[name] = float(pert.params[name])
        else:
            out[name] = pert.bead_values(name, beads)
    return out


def bead_params(chain: Mapping[str, Any]) -> dict[str, float | np.ndarray]:
    """Parameter values of a plain chain (studies/points.py): floats, or per-bead arrays (random draws
    by :func:`pulsemap.symbolic.param_forms.uniform_draw`, as the symbolic side draws them)."""
    beads = int(chain["beads"])
    out: dict[str, float | np.ndarray] = {}
    for name, value in chain["params"].items():
        if isinstance(value, Mapping):
            if set(value) != {"uniform", "seed"}:
                raise SweepError(f"parameter '{name}': a random draw is {{uniform: [lo, hi], seed: s}}, got {value!r}")
            lo, hi = value["uniform"]
            out[name] = uniform_draw(lo, hi, value["seed"], beads)
        elif isinstance(value, list):
            if len(value) != beads:
                raise SweepError(f"parameter '{name}' has {len(value)} per-bead values for {beads} beads")
            out[name] = np.asarray(value, dtype=float)
        else:
            out[name] = float(value)
    return out


def make_force(scene: Scene, beads: int) -> OnSiteForce:
    """eps_i R_i(x_i, v_i) for the DNS from the generated force module (zero before first_perturbed):
    :func:`chain_force`, refused unless R(0, 0) = 0 on every bead (the chain starts at rest); kept
    in-process for the next run of the same resolved force."""
    pert = scene.perturbation
    key = (pert.text, float(pert.eps), pert.params, int(scene.first_perturbed), int(beads),
           str(codeload.PACKAGE_DIR), str(cache_root()))  # and where its generated module comes from
    force = _FORCES.pop(key, None)
    if force is None:
        force = _build_force(scene, beads)
        while len(_FORCES) >= _FORCES_KEPT:
            del _FORCES[next(iter(_FORCES))]
    _FORCES[key] = force
    return force


def _build_force(scene: Scene, beads: int) -> OnSiteForce:
    pert = scene.perturbation
    mod = force_module(pert.text, pert.used_parameters)
    chain = {"beads": beads, "first_perturbed": scene.first_perturbed, "eps": float(pert.eps)}
    values = parameter_values(scene, beads)
    try:
        force = chain_force(mod, chain, values)
        k = _distinct_beads(mod, chain, values)  # beads past k repeat bead k
        zeros = np.zeros(k)
        with np.errstate(all="ignore"):
            f0 = np.asarray(force.restrict(0, k).force(zeros, zeros), dtype=float)
    except SweepError as exc:
        raise RunError(str(exc)) from None
    except (ValueError, ZeroDivisionError, FloatingPointError) as exc:
        raise RunError(f"the on-site force cannot be evaluated at rest: {exc}") from None
    if not np.all(np.isfinite(f0)):
        raise RunError("the on-site force is undefined at rest (non-finite value): check R and its parameters")
    if np.any(np.abs(f0) > 1e-12):
        k = int(np.argmax(np.abs(f0)))
        eps_k = float(pert.eps) if k + 1 >= scene.first_perturbed else 0.0
        raise RunError(f"R(0, 0) = {f0[k] / max(eps_k, 1e-300):.6g} at bead {k + 1}: the chain would not start at rest")
    return force


def _distinct_beads(module, chain: Mapping[str, Any], values: Mapping[str, Any]) -> int:
    """How many leading beads carry every distinct value of the force: first_perturbed when R is
    uniform (no i in R, scalar parameters: beads past it repeat it), else the whole chain."""
    beads = int(chain["beads"])
    uses_i = "i" in re.findall(r"[A-Za-z_][A-Za-z0-9_]*", str(module.SOURCE["R"]))
    if uses_i or any(np.ndim(values[name]) for name in module.PARAMS):
        return beads
    return min(beads, int(chain["first_perturbed"]))


class _Beads:
    """Bead indices i and eps_i of beads lo..hi-1 (0-based), made when first read."""

    def __init__(self, lo: int, hi: int, first_perturbed: int, eps: float) -> None:
        self.lo, self.hi, self.first_perturbed, self.eps_value = lo, hi, first_perturbed, eps

    @cached_property
    def i(self) -> np.ndarray:
        return np.arange(self.lo + 1, self.hi + 1, dtype=float)

    @cached_property
    def eps(self) -> np.ndarray:
        return np.where(self.i >= self.first_perturbed, self.eps_value, 0.0)


def chain_force(module, chain: Mapping[str, Any], values: Mapping[str, Any] | None = None) -> OnSiteForce:
    """eps_i R_i(x_i, v_i) (zero before first_perturbed) from a generated force module, Eq. 1.

    ``restrict(lo, hi)`` gives the same force on beads lo..hi-1, so a moving-window DNS pays
    for its window only; ``monomials`` is the same force as a table for the compiled engine.
    Only ``chain["beads"]``, ``["first_perturbed"]`` and ``["eps"]`` are read (and
    ``["params"]`` when ``values`` is not given). A force that cannot be evaluated at rest, or
    is not finite there, is a SweepError.
    """
    beads, fp, eps_value = int(chain["beads"]), int(chain["first_perturbed"]), float(chain["eps"])
    values = bead_params(chain) if values is None else values
    full = tuple(values[name] if np.ndim(values[name]) else float(values[name]) for name in module.PARAMS)
    head = _Beads(0, _distinct_beads(module, chain, values), fp, eps_value)  # every distinct bead
    idx, eps = head.i, head.eps
    args0 = tuple(a[: idx.size] if np.ndim(a) else a for a in full)
    zeros = np.zeros(idx.size)
    try:
        with np.errstate(all="ignore"):
            kx = np.abs(np.asarray(module.force_dx(zeros, zeros, idx, eps, *args0), dtype=float))
            kv = np.abs(np.asarray(module.force_dv(zeros, zeros, idx, eps, *args0), dtype=float))
    except (ValueError, ZeroDivisionError, FloatingPointError) as exc:
        raise SweepError(f"the on-site force cannot be evaluated at rest: {exc}") from None
    if not (np.all(np.isfinite(kx)) and np.all(np.isfinite(kv))):
        raise SweepError("the on-site force is undefined at rest (non-finite value): check R and its parameters")
    hint = float(max(kv.max(initial=0.0), math.sqrt(kx.max(initial=0.0))))

    def build(lo: int, hi: int, monomials=None, jit=None) -> OnSiteForce:
        b = _Beads(lo, hi, fp, eps_value)
        args = tuple(a[lo:hi] if np.ndim(a) else a for a in full)
        return OnSiteForce(
            force=lambda x, v: module.force(x, v, b.i, b.eps, *args),
            dforce_dx=lambda x, v: module.force_dx(x, v, b.i, b.eps, *args),
            dforce_dv=lambda x, v: module.force_dv(x, v, b.i, b.eps, *args),
            stiffness_hint=hint,
            restrict=build,
            monomials=monomials,
            jit=jit,
        )

    table = table_from_module(module, idx, eps, args0)  # the table: the compiled engine's F
    return build(0, beads, table, None if table is not None else _once(lambda: numba_force(module, idx, eps, args0)))


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
