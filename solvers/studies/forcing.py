"""The on-site force eps_i R_i(x_i, v_i) of a scene for the DNS, and its parameter values per bead."""

from __future__ import annotations

import numpy as np

from pulsemap.solvers.chain.dns import OnSiteForce
from pulsemap.solvers.data.scene import Scene
from pulsemap.solvers.models.codeload import force_module
from pulsemap.solvers.studies.methods import RunError
from pulsemap.solvers.studies.points import chain_force
from pulsemap.solvers.studies.sweep import SweepError

__all__ = ["make_force", "parameter_values"]


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


def make_force(scene: Scene, beads: int) -> OnSiteForce:
    """eps_i R_i(x_i, v_i) for the DNS from the generated force module (zero before first_perturbed):
    points.chain_force, refused unless R(0, 0) = 0 on every bead (the chain starts at rest)."""
    pert = scene.perturbation
    mod = force_module(pert.text, pert.used_parameters)
    chain = {"beads": beads, "first_perturbed": scene.first_perturbed, "eps": float(pert.eps)}
    values = parameter_values(scene, beads)
    zeros = np.zeros(beads)
    try:
        force = chain_force(mod, chain, values)
        with np.errstate(all="ignore"):
            f0 = np.asarray(force.force(zeros, zeros), dtype=float)
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
