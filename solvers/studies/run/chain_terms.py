"""The reduced models of a scene with a contact law's term P or bead masses.

The first-order energy law

    dA/dk = -eps_c sum_j c_j(k) m(k)^(-b_j/2) I_j A^(q_j) / ((n + 1) E_1)  [+ the on-site R's energy law]

(derive/contact.py, evaluated by models/contact_law.py) as ``energy-law`` (the ODE) and ``energy-map`` (the
energy stepped contact by contact), seeded like every model at contact first_perturbed - 1; ``relaxed`` of a
chain of varying masses (:func:`mass_relaxed`: models/mass_kernel.py; a contact term's relaxed map is the model
table's own, models/relaxed.py). Which models each kind of perturbation has is studies/run/kinds.py's table.
"""

from __future__ import annotations

import time

import numpy as np

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.studies.extent import dns_span, on_contacts
from pulsemap.solvers.studies.run import kinds

#: The models a scene with a contact law's term or masses runs here: name -> the law's form.
CHAIN_TERM_MODELS = {"energy-law": "law", "energy-map": "map"}
TITLES = {"energy-law": "first-order energy law of the contact law's term and the masses (+ R's): "
                        "E_1 dA^(n+1)/dk = W(A)",
          "energy-map": "energy map of the contact law's term and the masses (+ R's): "
                        "E_1 A_k^(n+1) = E_1 A_(k-1)^(n+1) + W(A)"}


def has_chain_terms(scene) -> bool:
    """Whether the scene states a kind of perturbation besides the on-site R (kinds.KINDS: a contact term, masses)."""
    return any(kind.table != "perturbation" for kind in kinds.given(scene))


def mass_relaxed(state, name: str) -> dict:
    """``relaxed`` of a chain whose masses vary (no contact term, no R): the kernel in the local masses fitted to
    the model's own calibration chains (models/mass_kernel.py), from the run's seed peak."""
    from pulsemap.solvers.models.mass_kernel import MassKernelError, bead_velocity_peaks, kernel_peaks, mass_kernel

    scene, out = state.scene, state.out
    pert = scene.perturbation
    if scene.contact is not None or pert.acts:
        raise MassKernelError("relaxed: a chain with masses and a contact term or an on-site R has no relaxed model "
                            "yet; energy-law and the DNS run it")
    beads, _ = dns_span(scene)
    kernel = mass_kernel(float(scene.exponent))
    masses = scene.masses.bead_masses(beads)
    contacts, peaks = kernel_peaks(kernel, masses, float(out["seed"]["peak"]), scene.first_perturbed - 1,
                                   scene.contacts[1])
    out["peaks"][name] = on_contacts(state.contacts, contacts, peaks)
    vbeads, velocity = bead_velocity_peaks(kernel.n, masses, float(out["seed"]["peak"]), contacts, peaks)
    return {"status": "ok", "kernel": "local masses (models/mass_kernel.py)", "calibration_runs": kernel.runs,
            "bulk_accuracy_log_ratio": kernel.residual,
            "velocity_peaks": {"beads": [int(b) for b in vbeads], "peaks": [float(v) for v in velocity]}}


def _law_inputs(scene, beads: int):
    """(monomials with one coefficient symbol each, their per-contact values indexed from contact 0, masses
    indexed from bead 0): the scene's P with eps, first_perturbed and parameters folded into numbers."""
    import sympy

    from pulsemap.symbolic.contact import ContactMonomial

    monomials, params = [], {}
    law = scene.contact
    if law is not None and law.eps != 0.0:
        _, coef = law.table(beads - 1)
        for j, m in enumerate(law.monomials):
            name = f"c{j}"
            monomials.append(ContactMonomial(sympy.Symbol(name), m.a, m.b))
            params[name] = np.concatenate([[0.0], coef[j]])
    masses = None if scene.masses is None else np.concatenate([[1.0], scene.masses.bead_masses(beads)])
    return tuple(monomials), params, masses


def _onsite_terms(scene) -> tuple:
    """The on-site R's energy law as terms (q, rate) dA/dk = rate A^q, () without R (uniform R only)."""
    pert = scene.perturbation
    if not pert.acts:
        return ()
    from pulsemap.symbolic.balance import derive_balance
    from pulsemap.symbolic.contact import amplitude_terms

    parsed = getattr(pert, "parsed", pert)
    if not parsed.is_uniform:
        raise PulsemapError(f"R = {pert.text} varies along the chain: the combined energy law takes a uniform R")
    return amplitude_terms(derive_balance(parsed, "energy", n=scene.exponent).law)


def run_chain_term_models(state) -> None:
    """energy-law and energy-map of a scene with a contact-law term or masses, into the run's result, from the
    run's seed (run/models.seed_models: a given peak, the DNS's, or v0's); a model that cannot run says why in
    its own entry."""
    from pulsemap.symbolic.profile import exact_profile
    from pulsemap.solvers.models.contact_law import contact_law_peaks
    from pulsemap.solvers.studies.run.models import seed_models

    scene, out = state.scene, state.out
    asked = [m for m in state.methods if m in CHAIN_TERM_MODELS]
    if not asked:
        return
    beads, _ = dns_span(scene)
    seed_models(state, exact_profile(scene.exponent).S0)
    seed_peak, seed_contact = float(out["seed"]["peak"]), int(out["seed"]["contact"])
    t0 = time.perf_counter()
    try:  # the law's inputs, once for every form asked
        (monomials, params, masses), extra = _law_inputs(scene, beads), _onsite_terms(scene)
    except PulsemapError as exc:
        for m in asked:
            out[m] = {"model": TITLES[m], "refused": str(exc)}
            state.warnings.append(f"{m} refused: {exc}")
        return
    inputs_s = time.perf_counter() - t0
    for m in asked:
        t0 = time.perf_counter()
        try:
            run = contact_law_peaks(monomials, scene.exponent, 1.0, seed_peak, seed_contact, scene.contacts[1],
                                    params=params, masses=masses, extra_terms=extra, form=CHAIN_TERM_MODELS[m])
        except PulsemapError as exc:
            out[m] = {"model": TITLES[m], "refused": str(exc)}
            state.warnings.append(f"{m} refused: {exc}")
            continue
        state.timings[m] = inputs_s + time.perf_counter() - t0
        contacts = [int(c) for c in run.contacts]
        out["peaks"][m] = on_contacts(state.contacts, contacts, run.peaks)
        out[m] = {"model": TITLES[m], "profile": run.profile, "status": run.status, "tolerance": run.tolerance,
                  "ended_at": run.ended_at,
                  "velocity_peaks": {"beads": [int(b) for b in run.beads],
                                     "peaks": [None if v is None else float(v) for v in run.velocity_peaks]}
                  if scene.masses is not None else None}
        if run.status != "ok":
            state.warnings.append(f"{m}: the law ended ({run.status}) at contact index {run.ended_at:.6g}")


__all__ = ["CHAIN_TERM_MODELS", "has_chain_terms", "mass_relaxed", "run_chain_term_models"]
