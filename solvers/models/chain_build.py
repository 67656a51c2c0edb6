"""The chain of paper Eq. 1 built from plain data, in one place: a scene's DNS, a sweep task, a bench line
and a relaxed segment run all describe their chain as a :class:`ChainSpec` and call :func:`build_chain`.

The on-site force eps_i R_i comes from R's generated force module (:mod:`~pulsemap.solvers.models.codeload`,
or a module the caller loaded by name and hash), made by :func:`~pulsemap.solvers.models.onsite.onsite_force`
(monomial table or generated numba force for the compiled engine), refused unless R(0, 0) = 0 on every bead
(the chain starts at rest), and kept in-process by its resolved inputs, so a second run of the same chain
neither loads the module again nor rebuilds the table. The contact law's term and the masses are data of
the whole chain (chain/contact_force.py).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from pulsemap.symbolic.cache import cache_root
from pulsemap.symbolic.param_forms import uniform_draw
from pulsemap.solvers.chain.contact_force import ContactTable
from pulsemap.solvers.chain.dns import Chain, OnSiteForce
from pulsemap.solvers.chain.launch import Launch
from pulsemap.solvers.models import codeload
from pulsemap.solvers.models.onsite import ForceError, distinct_beads, onsite_force

__all__ = ["ChainSpec", "ForceError", "build_chain", "build_force", "plain_values"]

#: How many built forces a process keeps (most recent last): a run, its sweeps and its bench reuse them.
FORCES_KEPT = 32
#: The process's built forces by ChainSpec.force_key (the one store; build_force alone reads and writes it).
_FORCES: dict[tuple, OnSiteForce] = {}


@dataclass(frozen=True, eq=False)
class ChainSpec:
    """Eq. 1 of a chain as plain data: N, n, v0; R's text with its parameter names (the generated module's
    order), their values (numbers or per-bead arrays), eps (a number or per-bead array) and the first perturbed
    bead; the contact law's term as (exponents, coefficients over contacts 1..N-1, eps folded in) and the N
    bead masses (None: Hertz alone, unit masses)."""

    beads: int
    exponent: float
    velocity: float
    R: str = "0"
    params: tuple[str, ...] = ()
    values: Mapping[str, object] = field(default_factory=dict)
    eps: object = 0.0
    first_perturbed: int = 1
    contact: tuple[np.ndarray, np.ndarray] | None = None
    masses: np.ndarray | None = None

    @property
    def has_force(self) -> bool:
        """False for R = "0": the bare chain."""
        return self.R != "0"

    def force_key(self) -> tuple:
        """The resolved on-site force, as the in-process store keys it (arrays by their bytes' digest)."""
        def value(v):
            if np.ndim(v):
                a = np.ascontiguousarray(v, dtype=float)
                return ("array", a.shape, hashlib.blake2b(a.tobytes(), digest_size=16).hexdigest())
            return float(v)

        return (self.R, self.params, tuple((k, value(self.values[k])) for k in self.params), value(self.eps),
                int(self.first_perturbed), int(self.beads), str(codeload.PACKAGE_DIR), str(cache_root()))


def build_force(spec: ChainSpec, module=None, keep: bool = True) -> OnSiteForce | None:
    """eps_i R_i of the chain (zero before first_perturbed; None for the bare chain) from R's generated force
    module (``module``: one the caller loaded by name and hash, else codeload.force_module). ForceError when R
    cannot be evaluated at rest, is not finite there, or R(0, 0) != 0 on some bead. ``keep``: look the force up
    in, and keep it in, the process's store of built forces (by :meth:`ChainSpec.force_key`)."""
    if not spec.has_force:
        return None
    key = spec.force_key() if keep else None
    force = _FORCES.pop(key, None) if keep else None
    if force is None:
        force = _checked_force(spec, module if module is not None else codeload.force_module(spec.R, spec.params))
        while keep and len(_FORCES) >= FORCES_KEPT:
            del _FORCES[next(iter(_FORCES))]
    if keep:
        _FORCES[key] = force
    return force


def _checked_force(spec: ChainSpec, module) -> OnSiteForce:
    beads, fp = int(spec.beads), int(spec.first_perturbed)
    eps = np.asarray(spec.eps, float) if np.ndim(spec.eps) else float(spec.eps)
    force = onsite_force(module, beads, fp, eps, spec.values)
    k = distinct_beads(module, beads, fp, eps, spec.values)  # beads past k repeat bead k
    zeros = np.zeros(k)
    try:
        with np.errstate(all="ignore"):
            f0 = np.asarray(force.restrict(0, k).force(zeros, zeros), dtype=float)
    except (ValueError, ArithmeticError) as exc:
        raise ForceError(f"the on-site force cannot be evaluated at rest: {exc}") from None
    if not np.all(np.isfinite(f0)):
        raise ForceError("the on-site force is undefined at rest (non-finite value): check R and its parameters")
    if np.any(np.abs(f0) > 1e-12):
        b = int(np.argmax(np.abs(f0)))
        eps_b = float(eps[b] if np.ndim(eps) else eps) if b + 1 >= fp else 0.0
        raise ForceError(f"R(0, 0) = {f0[b] / max(eps_b, 1e-300):.6g} at bead {b + 1}: the chain would not start "
                         "at rest")
    return force


def build_chain(spec: ChainSpec, module=None, keep: bool = True, launch: Launch | None = None) -> Chain:
    """The chain of Eq. 1 the DNS takes: :func:`build_force`, the contact law's term and the masses
    (``launch``: an exact solitary wave instead of the impact)."""
    contact = None if spec.contact is None else ContactTable(*spec.contact)
    return Chain(int(spec.beads), float(spec.exponent), float(spec.velocity), build_force(spec, module, keep),
                 launch=launch, contact=contact, masses=spec.masses)


def plain_values(params: Mapping[str, object], beads: int) -> dict[str, float | np.ndarray]:
    """Parameter values of a plain chain (a sweep task's dict): floats, per-bead lists, or random draws
    ``{"uniform": [lo, hi], "seed": s}`` (drawn by :func:`pulsemap.symbolic.param_forms.uniform_draw`, as the
    symbolic side draws them). ForceError on a malformed value."""
    out: dict[str, float | np.ndarray] = {}
    for name, value in params.items():
        if isinstance(value, Mapping):
            if set(value) != {"uniform", "seed"}:
                raise ForceError(f"parameter '{name}': a random draw is {{uniform: [lo, hi], seed: s}}, got {value!r}")
            lo, hi = value["uniform"]
            out[name] = uniform_draw(lo, hi, value["seed"], beads)
        elif isinstance(value, list):
            if len(value) != beads:
                raise ForceError(f"parameter '{name}' has {len(value)} per-bead values for {beads} beads")
            out[name] = np.asarray(value, dtype=float)
        else:
            out[name] = float(value)
    return out
