"""The on-site force eps_i R_i(x_i, v_i) of a scene for the DNS (paper Eq. 1), built in one place.

A scene's force goes one way down: its parameter values per bead (:func:`parameter_values`, or
:func:`bead_params` from a sweep's plain chain), the generated force module
(:mod:`~pulsemap.solvers.models.codeload`), then :func:`chain_force`, the OnSiteForce the DNS takes
with its monomial table or generated numba force (built by :mod:`~pulsemap.solvers.models.onsite`,
which the relaxed model's segment runs use too).
:func:`make_force` keeps what it built for a scene in-process (keyed by the resolved force: R, eps,
parameter values, first_perturbed, beads, and where generated modules are read), so a second run of
a scene neither loads the generated module again nor rebuilds the table.
Per-bead data stays O(window) when R is uniform (models/onsite.py); a site-dependent R is
O(beads) (its values are data of the whole chain).
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from pulsemap.symbolic.cache import cache_root
from pulsemap.symbolic.param_forms import uniform_draw
from pulsemap.solvers.chain.dns import OnSiteForce
from pulsemap.solvers.data.scene import Scene
from pulsemap.solvers.models import codeload
from pulsemap.solvers.models.codeload import force_module
from pulsemap.solvers.models.onsite import ForceError, distinct_beads, onsite_force
from pulsemap.solvers.studies.methods import RunError
from pulsemap.solvers.studies.sweep import SweepError

__all__ = ["bead_params", "chain_force", "force_failure", "make_force", "out_of_range", "parameter_values"]

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
        k = distinct_beads(mod, beads, scene.first_perturbed, float(pert.eps), values)  # beads past k repeat bead k
        zeros = np.zeros(k)
        with np.errstate(all="ignore"):
            f0 = np.asarray(force.restrict(0, k).force(zeros, zeros), dtype=float)
    except SweepError as exc:
        raise RunError(_at_rest(scene, beads) or str(exc)) from None
    except (ValueError, ArithmeticError) as exc:
        raise RunError(_at_rest(scene, beads) or f"the on-site force cannot be evaluated at rest: {exc}") from None
    if not np.all(np.isfinite(f0)):
        raise RunError(_at_rest(scene, beads)
                       or "the on-site force is undefined at rest (non-finite value): check R and its parameters")
    if np.any(np.abs(f0) > 1e-12):
        k = int(np.argmax(np.abs(f0)))
        eps_k = float(pert.eps) if k + 1 >= scene.first_perturbed else 0.0
        raise RunError(f"R(0, 0) = {f0[k] / max(eps_k, 1e-300):.6g} at bead {k + 1}: the chain would not start at rest")
    return force


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


def chain_force(module, chain: Mapping[str, Any], values: Mapping[str, Any] | None = None) -> OnSiteForce:
    """eps_i R_i(x_i, v_i) (zero before first_perturbed) from a generated force module, Eq. 1
    (:func:`~pulsemap.solvers.models.onsite.onsite_force`). Only ``chain["beads"]``,
    ``["first_perturbed"]`` and ``["eps"]`` are read (and ``["params"]`` when ``values`` is not
    given). A force that cannot be evaluated at rest, or is not finite there, is a SweepError.
    """
    values = bead_params(chain) if values is None else values
    try:
        return onsite_force(module, int(chain["beads"]), int(chain["first_perturbed"]), float(chain["eps"]), values)
    except ForceError as exc:
        raise SweepError(str(exc)) from None


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
        size = Scaling(scene.exponent, scene.velocity).unit_force_size(make_force(scene, beads), beads)
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
