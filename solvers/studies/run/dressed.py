"""The dressed law (method ``dressed-law``) in a run: form it (studies/dressed.py), seed it, evaluate it."""

from __future__ import annotations

import time
from dataclasses import replace

from pulsemap.solvers.models.dressed import evaluate_dressed_law
from pulsemap.solvers.studies.extent import on_contacts
from pulsemap.solvers.studies.run.state import RunState


def prepare_dressed(state: "RunState") -> tuple[object | None, str | None]:
    """(the dressed law for the scene's R, None), or (None, why it is refused)."""
    from pulsemap.symbolic.dressed import DressedError  # sympy: only when the dressed law is asked for
    from pulsemap.solvers.studies.dressed import dressed_law

    scene = state.scene
    why, law = None, None
    if state.choice.profile != "exact":
        why = "the dressed law uses the exact profile (its coefficients come from launched exact solitons)"
    else:
        t0 = time.perf_counter()
        try:
            law = dressed_law(scene.perturbation, scene.exponent, at_bead=float(scene.first_perturbed) - 0.5)
        except DressedError as exc:
            why = str(exc)
        state.timings["derive_dressed"] = time.perf_counter() - t0
    return law, why


def provenance(law, kind: str) -> list[str]:
    """Which coefficients of the law (``monomial:k2_over_k1``, ``monomial:onset_lag``, ``cross:j x l``) are
    ``kind`` ("derived" or "calibrated"); k1 is always derived (energy balance)."""
    out = []
    for t in law.terms:
        out += [f"{t.monomial}:{name}" for name, method in (("k2_over_k1", t.rho_method), ("onset_lag", t.lag_method))
                if method.startswith(kind)]
    return out + [f"cross:{ct.first} x {ct.second}" for ct in law.cross if ct.method.startswith(kind)]


def run_dressed(state: "RunState", name: str, law, seed_A: float, S0: float) -> dict:
    """Evaluate the dressed law from the seed A (contact first_perturbed - 1, converted with S0: peak = A S0)
    over the scene's contacts; its entry of the result."""
    from pulsemap.solvers.studies.dressed import coefficients, site_coefficient_functions

    scene, out = state.scene, state.out
    t0 = time.perf_counter()
    coef = coefficients(law)
    i0 = float(scene.first_perturbed - 1)
    if not scene.perturbation.is_uniform:  # c_j(i) along the chain (bead i + 1/2 at contact index i)
        coef = replace(coef, c_of_i=site_coefficient_functions(scene.perturbation, law, i0, float(scene.contacts[1])))
    ev = evaluate_dressed_law(coef, S0, seed_A, i0, state.contacts)
    run, beyond = ev.run, ev.beyond
    state.timings[name] = time.perf_counter() - t0
    out["peaks"][name] = on_contacts(state.contacts, run.contacts, run.peaks)
    given = [a for a in ev.accuracy if a is not None]
    info = {"profile": "exact", "status": run.status, "message": run.message,
            "ended_at": run.ended_at, "law_kind": run.law_kind, "beyond_validity_at": beyond,
            "accuracy": on_contacts(state.contacts, run.contacts, ev.accuracy),
            "note": (f"estimated accuracy +-{100 * max(given):.2g} % (largest over the values given)" if given
                     else f"no value: {run.message}"),
            "coefficients": {t.monomial: {"k1": t.k1, "k2_over_k1": t.rho, "onset_lag": t.lag}
                             for t in law.terms},
            "derived": provenance(law, "derived"), "calibrated": provenance(law, "calibrated")}
    if run.status != "ok":
        state.warnings.append(f"{name}: {run.message}")
    if beyond is not None and beyond <= state.contacts[-1] and run.status != "beyond its validity bound":
        state.warnings.append(f"{name}: from contact index {beyond:.4g} some |x_j| exceeds the two-term law's "
                              "validity bound (derive --model dressed prints it): its error grows there")
    return info
