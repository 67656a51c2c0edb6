"""A scene's chain for the DNS (paper Eq. 1): the scene as plain data (:func:`chain_spec`), built by the one
builder below the studies (:func:`pulsemap.solvers.models.chain_build.build_chain`), which run, sweeps,
bench and the relaxed model's segment runs share.

What stays here is the scene's side: its parameter values per bead (:func:`parameter_values`), and the
messages that read the scene's own R (sympy) to name the term that fails (:func:`force_failure`,
:func:`out_of_range`, the refusal at rest). Per-bead data stays O(window) when R is uniform
(models/onsite.py); a site-dependent R is O(beads) (its values are data of the whole chain).
"""

from __future__ import annotations

import numpy as np

from pulsemap.solvers.chain.dns import Chain, OnSiteForce
from pulsemap.solvers.data.scene import Scene
from pulsemap.solvers.models.chain_build import ChainSpec, ForceError, build_chain, build_force
from pulsemap.solvers.studies.methods import RunError

__all__ = ["chain_spec", "force_failure", "make_force", "out_of_range", "parameter_values", "scene_chain"]


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


def chain_spec(scene: Scene, beads: int, bare_if_zero: bool = True) -> ChainSpec:
    """The scene's chain of ``beads`` beads as plain data: R with its eps and values (left out when R = 0 or
    eps = 0 and ``bare_if_zero``: the bare chain, which conserves energy, its drift checking the run), the
    contact law's table over contacts 1..N-1 (eps folded in) and the masses."""
    pert = scene.perturbation
    law = scene.contact
    contact = None if law is None or law.eps == 0.0 else law.table(beads - 1)
    masses = None if scene.masses is None else scene.masses.bead_masses(beads)
    on = pert.acts or not bare_if_zero
    return ChainSpec(int(beads), float(scene.exponent), float(scene.velocity),
                     R=pert.text if on else "0", params=tuple(pert.used_parameters) if on else (),
                     values=parameter_values(scene, beads) if on else {}, eps=float(pert.eps) if on else 0.0,
                     first_perturbed=int(scene.first_perturbed), contact=contact, masses=masses)


def scene_chain(scene: Scene, beads: int) -> Chain:
    """The chain of the scene's DNS (:func:`chain_spec` built by build_chain); RunError naming R's failing term
    when the chain cannot start at rest."""
    try:
        return build_chain(chain_spec(scene, beads))
    except ForceError as exc:
        raise RunError(_at_rest(scene, beads) or str(exc)) from None


def make_force(scene: Scene, beads: int) -> OnSiteForce | None:
    """eps_i R_i(x_i, v_i) of the scene for the DNS (zero before first_perturbed; eps = 0 too; None for a scene
    without R): build_force of its :func:`chain_spec`, refused (RunError) unless R(0, 0) = 0 on every bead."""
    try:
        return build_force(chain_spec(scene, beads, bare_if_zero=False))
    except ForceError as exc:
        raise RunError(_at_rest(scene, beads) or str(exc)) from None


def _at_rest(scene: Scene, beads: int, scan: int = 64) -> str | None:
    """The first perturbed bead (of the first ``scan``) where R or its slope in u or v is not a finite real
    number at rest (u = v = 0), with the term and what it is there (derive's failing_term); None if none."""
    import sympy

    from pulsemap.symbolic.expression import failing_term, symbol

    pert = scene.perturbation
    values = parameter_values(scene, beads)
    for bead in range(scene.first_perturbed, min(beads, scene.first_perturbed + scan) + 1):
        point = {"u": 0.0, "v": 0.0, "i": float(bead)}
        point.update({name: float(v[bead - 1]) if np.ndim(v) else float(v) for name, v in values.items()})
        for what, expr in (("R", pert.R), ("dR/du", sympy.diff(pert.R, symbol("u"))),
                           ("dR/dv", sympy.diff(pert.R, symbol("v")))):
            found = failing_term(expr, point)
            if found is not None:
                return (f"R = {pert.text}: {what} is {found[1]} at rest on bead {bead} (its term {found[0]} is "
                        f"{found[1]} there): R and its slopes must be finite and real at u = v = 0 on every bead")
    return None


def force_failure(scene: Scene, beads: int, exc: ArithmeticError, who: str) -> str:
    """One line for a run ``who`` (the DNS, the relaxed map's segment runs) stopped by the force itself:
    when, at which bead, R's term that is not finite or not real there (derive's failing_term), the fix."""
    from pulsemap.symbolic.expression import failing_term, singular_terms

    pert = scene.perturbation
    fix = "R must stay finite and real for every u, v the chain reaches (move the singularity out of reach or bound R)"
    bead = getattr(exc, "bead", None)
    if bead is None:  # not located: R's terms that can be infinite, as a hint
        terms = singular_terms(pert.R)
        zero = (terms[0].base if terms[0].is_Pow else terms[0].args[0]) if terms else None
        hint = f": its term {terms[0]} is infinite where {zero} = 0" if terms else ""
        return f"{who} stopped: R = {pert.text} gave {type(exc).__name__} ({exc}){hint}; {fix}"
    values = {"u": exc.x, "v": exc.v, "i": float(bead)}
    for name, value in parameter_values(scene, beads).items():
        values[name] = float(value[min(bead, np.size(value)) - 1]) if np.ndim(value) else float(value)
    found = failing_term(pert.R, values)
    term = f": its term {found[0]} is {found[1]} there" if found is not None else ""
    when = f" at t = {exc.t:.6g}" if exc.t is not None else ""
    return (f"{who} stopped{when}: R = {pert.text} is not finite (or not real) at bead {bead} (u = {exc.x:.6g}, "
            f"v = {exc.v:.6g}; the on-site {exc.what} is {exc.value}){term}; {fix}")


def out_of_range(scene: Scene) -> str | None:
    """The values of eps and the parameters named, when eps R on the wave is more than FORCE_LIMIT times the
    contact forces (chain/scaling: the largest on-site force the integrator holds, probed over the wave's
    strains and velocities in the unit frame of v0): the integrator cannot follow it and the models' expansion
    in small eps R does not hold. None when eps R is within it (or cannot be built)."""
    from pulsemap.solvers.chain.equations import chain_length_for
    from pulsemap.solvers.chain.scaling import FORCE_LIMIT, Scaling

    beads = scene.beads or chain_length_for(scene.contacts[1])
    try:
        force = make_force(scene, beads)
        if force is None:  # no on-site R: nothing to be out of range
            return None
        size = Scaling(scene.exponent, scene.velocity).unit_force_size(force, beads)
    except (ValueError, ArithmeticError):
        return None
    if size <= FORCE_LIMIT:
        return None
    pert = scene.perturbation
    values = [f"eps = {pert.eps:.6g}"]
    for name, value in parameter_values(scene, beads).items():
        if np.ndim(value):
            big = float(np.max(np.abs(value)))
            values.append(f"{name} up to {big:.6g} in magnitude" if np.isfinite(big) else f"{name} beyond float64")
        else:
            values.append(f"{name} = {value:.6g}")
    shown = "inf" if not np.isfinite(size) else f"{size:.3g}"
    return (f"{', '.join(values)} is beyond the range the DNS and the models hold: eps R reaches {shown} times the "
            f"contact forces on the wave (limit {FORCE_LIMIT:g}); lower eps or the parameters")
