"""The reduced models of a run: derive their modules, seed them, iterate the maps and evaluate the laws.

Each step fills the run's result (``state.out``): peaks per contact, a description per model,
timings and warnings, exactly as :func:`pulsemap.solvers.studies.run.run_scene` reports them.
"""

from __future__ import annotations

import contextlib
import time
from types import ModuleType

import numpy as np

from pulsemap.symbolic.profile import exact_profile
from pulsemap.solvers.models.balance_eval import BalanceRun, evaluate_balance_law, iterate_balance_map
from pulsemap.solvers.models.codeload import balance_module, force_module, map_module
from pulsemap.solvers.models.energy_quadrature import bead_force, evaluate_energy_law, iterate_energy_map, off_poles
from pulsemap.solvers.models.site_law_eval import evaluate_site_law
from pulsemap.solvers.studies.run.dressed import prepare_dressed, run_dressed
from pulsemap.solvers.models.longwave_eval import evaluate_law
from pulsemap.solvers.models.map_iteration import contact_params, eps0_ratio, iterate_map
from pulsemap.solvers.chain.equations import ForceNotFinite, chain_length_for
from pulsemap.solvers.studies.forcing import force_failure, make_force, out_of_range, parameter_values
from pulsemap.solvers.studies.methods import (
    BALANCE_METHODS,
    DRIFT_WARN,
    FORCING_WARN,
    MODEL_TITLES,
    WIDTH_WARN,
)
from pulsemap.solvers.studies.points import on_contacts
from pulsemap.solvers.studies.run.state import RunState


def _eps0_drift(mod, seed_contact: int, last: int, prm: dict) -> float | None:
    """Relative change of A over contacts seed_contact+1..last when eps = 0 (0 for 'corrected' and '1d')."""
    ratio = eps0_ratio(mod, contact_params(mod, prm, seed_contact + 1))
    return None if ratio is None else ratio ** (last - seed_contact) - 1.0


def _width_warning(mod) -> str | None:
    """Eq. 9 assumes delta_{i+2} = 0 while contact i is compressed: false for a wide pulse (n near 1)."""
    ratio = float(mod.f7) / float(mod.f1)
    if ratio <= WIDTH_WARN:
        return None
    return (f"the pulse spans more than two contacts at n = {float(mod.N_EXPONENT):g} (f7/f1 = {ratio:.3g} > "
            f"{WIDTH_WARN:g}): Eq. 9's assumption delta_(i+2) = 0 fails and the reduced models lose accuracy")


def derive_models(state: "RunState") -> tuple[ModuleType | None, dict[str, ModuleType]]:
    """The generated map module (map, longwave) and balance modules the methods need; a balance model
    undefined for R is reported as refused (pulsemap.symbolic.balance.BalanceError), not raised."""
    scene, choice, methods, out = state.scene, state.choice, state.methods, state.out
    pert = scene.perturbation
    site = pert.site_dependent
    mod = None
    balance: dict[str, ModuleType] = {}
    if not any(m in ("map", "longwave") or m in BALANCE_METHODS for m in methods):
        return mod, balance  # no generated model module needed (R is not parsed for a DNS alone)
    from pulsemap.symbolic.expression import is_polynomial_in_state  # sympy: the models derive from R

    polynomial = is_polynomial_in_state(pert.R)
    if "map" in methods or "longwave" in methods:
        if not polynomial:  # Eq. 23 and Eq. 30 integrate R monomial by monomial (Eq. 10)
            why = (f"R = {pert.R} is not a polynomial in u, v: the map (Eq. 23) and the long-wave law (Eq. 30) "
                   "integrate R monomial by monomial (Eq. 10); the DNS and the energy balance (by quadrature) still run")
            for m in ("map", "longwave"):
                if m in methods:
                    state.warnings.append(f"{m} refused: {why}")
                    out[m] = {"model": MODEL_TITLES[m], "refused": why}
        else:
            t0 = time.perf_counter()
            mod = map_module(pert.text, pert.used_parameters, scene.exponent, choice.profile, choice.variant, site)
            state.timings["derive_map"] = time.perf_counter() - t0
            wide = _width_warning(mod)
            if wide is not None:
                state.warnings.append(wide)
    for quantity in dict.fromkeys(BALANCE_METHODS[m][0] for m in methods if m in BALANCE_METHODS):
        t0 = time.perf_counter()
        if quantity == "energy" and not polynomial:
            balance[quantity] = QUADRATURE  # W(A) by quadrature of R over the wave (energy_quadrature.py)
            continue
        try:
            balance[quantity] = balance_module(pert.text, pert.used_parameters, scene.exponent, choice.profile,
                                               quantity, site)
        except ValueError as exc:  # the model is undefined for this R (pulsemap.symbolic.balance.BalanceError)
            for m in methods:
                if BALANCE_METHODS.get(m, ("",))[0] == quantity:
                    state.warnings.append(f"{m} refused: {exc}")
                    out[m] = {"model": MODEL_TITLES[m], "refused": str(exc)}
        state.timings[f"derive_{quantity}"] = time.perf_counter() - t0
    return mod, balance


def seed_models(state: "RunState", S0: float) -> float:
    """The amplitude A at contact first_perturbed - 1 that map and law start from (Eq. 32: peak / S0):
    a given peak, else the DNS peak there, else the impulse v0 through kappa_n."""
    scene = state.scene
    seed_contact = scene.first_perturbed - 1
    if state.given_seed is not None:
        seed_peak, seed_from = float(state.given_seed), "given peak (--seed-peak)"
    elif state.seed_peak is not None:
        seed_peak, seed_from = state.seed_peak, f"DNS peak at contact {seed_contact}"
    else:
        from pulsemap.solvers.chain.kappa import peak_from_velocity

        t0 = time.perf_counter()
        seed_peak = float(peak_from_velocity(scene.velocity, scene.exponent))
        state.timings["kappa"] = time.perf_counter() - t0
        seed_from = "impulse v0 through kappa_n (unperturbed incoming peak)"
    seed_A = seed_peak / S0
    state.out["seed"] = {"contact": seed_contact, "peak": seed_peak, "A": seed_A, "from": seed_from}
    return seed_A


def run_balance(state: "RunState", balance: dict[str, ModuleType], seed_A: float, prm: dict) -> None:
    """The energy- and momentum-balance maps and laws asked for (derive/balance.py)."""
    scene, out = state.scene, state.out
    pert = scene.perturbation
    seed_contact, c1 = scene.first_perturbed - 1, scene.contacts[1]
    for m in state.methods:
        if m not in BALANCE_METHODS or BALANCE_METHODS[m][0] not in balance:
            continue
        bmod = balance[BALANCE_METHODS[m][0]]
        t0 = time.perf_counter()
        if bmod is QUADRATURE:
            br = _quadrature_energy(state, BALANCE_METHODS[m][1], seed_A, prm)
        elif BALANCE_METHODS[m][1] == "map":
            br = iterate_balance_map(bmod, seed_A, seed_contact, c1, float(pert.eps), prm)
        elif not bmod.UNIFORM:  # coefficients varying along the chain (derive/site_law.py)
            br = evaluate_site_law(bmod, pert, "balance", seed_A, float(seed_contact), state.contacts)
            br = BalanceRun(bmod.MODEL, "law", br.contacts, br.A, br.peaks, br.ended or "ok",
                            f"{br.ended} at contact index {br.ended_at:.6g}" if br.ended else "ODE solved (LSODA, rtol 1e-11)",
                            br.ended_at, br.kind, bmod.SOURCE["profile"])
        else:
            br = evaluate_balance_law(bmod, seed_A, float(seed_contact), state.contacts, float(pert.eps), prm)
        state.timings[m] = time.perf_counter() - t0
        out["peaks"][m] = on_contacts(state.contacts, br.contacts, br.peaks)
        out[m] = {"model": MODEL_TITLES[m], "profile": br.profile, "status": br.status, "message": br.message,
                  "ended_at": br.ended_at, "law_kind": br.law_kind,
                  "generated": bmod.__name__ if bmod is not QUADRATURE else None}
        if br.status != "ok":
            state.warnings.append(f"{m}: {br.message}")


def run_map(state: "RunState", mod: ModuleType, seed_A: float, prm: dict) -> None:
    """The amplitude map (Eq. 23) from the seed, with the warnings on its assumptions."""
    scene, out, warnings = state.scene, state.out, state.warnings
    seed_contact, c1 = scene.first_perturbed - 1, scene.contacts[1]
    t0 = time.perf_counter()
    mr = iterate_map(mod, seed_A, seed_contact, c1, float(scene.perturbation.eps), prm)
    state.timings["map"] = time.perf_counter() - t0
    out["peaks"]["map"] = on_contacts(state.contacts, mr.contacts, mr.peaks)
    out["map"] = {"model": MODEL_TITLES["map"], "variant": mr.variant, "profile": mr.profile, "status": mr.status,
                  "message": mr.message, "newton_fallbacks": mr.fallbacks, "engine": mr.engine,
                  "generated": mod.__name__}
    out["map"]["max_forcing_ratio"] = mr.max_forcing_ratio  # |eps term| / contact term (map_iteration)
    if mr.status != "ok":
        warnings.append(f"map: {mr.message}")
    if mr.variant == "paper":
        drift = _eps0_drift(mod, seed_contact, c1, prm)
        out["map"]["eps0_drift"] = drift
        if drift is not None and abs(drift) > DRIFT_WARN:
            warnings.append(f"map: the 'paper' variant drifts by {100 * drift:+.3g} % over contacts "
                            f"{seed_contact + 1}..{c1} even at eps = 0 (erratum 5 in the docs, docs/errata.rst): "
                            "use --variant corrected or 1d")
    if mr.max_forcing_ratio is not None and mr.max_forcing_ratio > FORCING_WARN:
        k = int(np.argmax(mr.forcing_ratio > FORCING_WARN))
        warnings.append(f"map: at contact {int(mr.contacts[k])} the eps term of Eq. 23 exceeds "
                        f"{FORCING_WARN:g} of the contact term (max {mr.max_forcing_ratio:.3g} over the run): "
                        "outside the map's assumption eps*R << contact forces")


def run_longwave(state: "RunState", mod: ModuleType, seed_A: float, prm: dict) -> None:
    """The long-wave law (Eq. 30) from the seed; skipped for a site-dependent perturbation."""
    scene, out = state.scene, state.out
    t0 = time.perf_counter()
    if not mod.UNIFORM:  # coefficients varying along the chain (derive/site_law.py)
        law = evaluate_site_law(mod, scene.perturbation, "longwave", seed_A, float(scene.first_perturbed - 1),
                                state.contacts)
    else:
        law = evaluate_law(mod, seed_A, float(scene.first_perturbed - 1), state.contacts,
                           float(scene.perturbation.eps), prm)
    state.timings["longwave"] = time.perf_counter() - t0
    out["peaks"]["longwave"] = on_contacts(state.contacts, law.contacts, law.peaks)
    out["longwave"] = {"model": MODEL_TITLES["longwave"], "kind": law.kind, "ended_at": law.ended_at,
                       "ended": law.ended or None,
                       "profile": state.choice.profile}
    if law.ended:
        state.warnings.append(f"long-wave law: {law.ended} at contact index {law.ended_at:.4g}")


def run_relaxed(state: "RunState", prm: dict) -> None:
    """The relaxed transfer map with its onset (solvers/models/relaxed.py) from the seed peak; refused
    (reported, not raised) for an R it cannot take."""
    from pulsemap.solvers.models.relaxed import ONSET, RelaxedError, iterate_relaxed, model_for_scene
    from pulsemap.solvers.models.relaxed_table import SegmentRunError

    scene, out = state.scene, state.out
    seed_contact, c1 = scene.first_perturbed - 1, scene.contacts[1]
    t0 = time.perf_counter()
    try:
        model = model_for_scene(scene, prm)
        run = iterate_relaxed(model, float(out["seed"]["peak"]), seed_contact, c1)
        # the stated accuracy is part of the build the user waits for (a table row does not ask for it)
        accuracy = model.accuracy() if state.stated_accuracy else None
    except RelaxedError as exc:
        state.warnings.append(f"relaxed refused: {exc}")
        out["relaxed"] = {"model": MODEL_TITLES["relaxed"], "refused": str(exc)}
        return
    except SegmentRunError as exc:
        state.warnings.append(f"relaxed failed: {exc}")
        out["relaxed"] = {"model": MODEL_TITLES["relaxed"], "failed": str(exc)}
        return
    state.timings["relaxed"] = time.perf_counter() - t0
    out["peaks"]["relaxed"] = on_contacts(state.contacts, run.contacts, run.peaks)
    out["relaxed"] = {"model": MODEL_TITLES["relaxed"], "status": run.status, "message": run.message,
                      "onset_contacts": ONSET, "segment_runs": model.segment_runs(),
                      "tables": [t.spec.R for t in model.tables.values()],
                      "scaling_exponent": model.e}
    if accuracy is not None:
        out["relaxed"]["bulk_accuracy_log_ratio"] = accuracy
    if model.kernels:
        out["relaxed"]["kernel_runs"] = model.kernel_runs()
    if run.status != "ok":
        state.warnings.append(f"relaxed: {run.message}")


class ModelNumberError(ValueError):
    """A reduced model whose numbers left float64 (overflow, division by zero); names the model and the seed."""


@contextlib.contextmanager
def _float64_guard(what: str, state: "RunState"):
    """An ArithmeticError from generated code (A^P past 1e308, a division by zero) as one line naming
    the model, the seed and the fix."""
    try:
        yield
    except ForceNotFinite as exc:  # R itself, in a segment run of the DNS (the relaxed map)
        raise ModelNumberError(force_failure(state.scene, state.scene.beads, exc, f"{what}'s segment DNS")) from None
    except ValueError as exc:
        if type(exc) is not ValueError:  # the project's own errors say what they mean
            raise
        strong = out_of_range(state.scene)  # a numerical library's words ("f(a) and f(b) must have different signs")
        raise ModelNumberError(f"{what} stopped: " + (strong or f"the numerical library refused its input ({exc}): "
                                                      "please report this scene")) from None
    except ArithmeticError as exc:
        seed = state.out.get("seed", {})
        raise ModelNumberError(
            f"{what} stopped: {type(exc).__name__} ({exc}) from the seed peak {seed.get('peak', float('nan')):.6g} at "
            f"contact {seed.get('contact')} ({seed.get('from', '?')}): the amplitude or R's coefficients are too "
            "large for float64; give a smaller --seed-peak or scale R's parameters"
        ) from None


def run_models(state: "RunState") -> None:
    """Derive, seed and run every reduced model among the methods."""
    mod, balance = derive_models(state)
    dressed = prepare_dressed(state) if "dressed-law" in state.methods else None
    if mod is None and not balance and "relaxed" not in state.methods and dressed is None:
        return
    if not state.scene.perturbation.is_uniform:  # R or a parameter varies along the chain: real and finite at
        make_force(state.scene, state.scene.beads or chain_length_for(state.scene.contacts[1]))  # rest on each bead
    modules = [m for m in (mod, *balance.values()) if m is not None and m is not QUADRATURE]
    S0 = float(modules[0].S0 if modules else exact_profile(state.scene.exponent).S0)
    seed_A = seed_models(state, S0)
    prm = parameter_values(state.scene, state.scene.beads)
    if "relaxed" in state.methods:
        with _float64_guard("the relaxed map", state):
            run_relaxed(state, prm)
    with _float64_guard("the balance " + ", ".join(m for m in state.methods if m in BALANCE_METHODS), state):
        run_balance(state, balance, seed_A, prm)
    if "map" in state.methods and mod is not None:
        with _float64_guard("the map (Eq. 23)", state):
            run_map(state, mod, seed_A, prm)
    if "longwave" in state.methods and mod is not None:
        with _float64_guard("the long-wave law (Eq. 30)", state):
            run_longwave(state, mod, seed_A, prm)
    if dressed is not None:
        run_dressed(state, dressed, seed_A)


class _Quadrature:
    """Stands for the energy balance by quadrature (no generated module: R is not a polynomial)."""

    def __repr__(self) -> str:
        return "QUADRATURE"


QUADRATURE = _Quadrature()


def _quadrature_energy(state: "RunState", form: str, seed_A: float, prm: dict) -> BalanceRun:
    """Energy map or law for a non-polynomial R: W(A) by quadrature over the wave with the DNS's force
    module (solvers/models/energy_quadrature.py); bead parameters from the scene."""
    scene = state.scene
    pert = scene.perturbation
    fmod = force_module(pert.text, pert.used_parameters)

    def params_at(bead: float) -> tuple:
        return tuple(float(pert.values_at(name, [bead])[0]) for name in fmod.PARAMS)

    F = off_poles(bead_force(fmod, float(pert.eps), params_at), pert, fmod.PARAMS, params_at)
    seed_contact = scene.first_perturbed - 1
    if form == "map":
        return iterate_energy_map(F, scene.exponent, seed_A, seed_contact, scene.contacts[1])
    return evaluate_energy_law(F, scene.exponent, seed_A, float(seed_contact), state.contacts)
