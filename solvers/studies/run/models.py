"""The reduced models of a run: derive their modules, seed them, iterate the maps and evaluate the laws.

:data:`RUNNERS` is the model table (name -> title and runner): :func:`run_models` derives what the
models share, seeds them and runs each on its own, so a model that fails (raises a PulsemapError, or
its numbers leave float64) is reported in its own entry and every other model's results are written.
Each runner fills the run's result (``state.out``): peaks per contact, a description of the model,
timings and warnings, exactly as :func:`pulsemap.solvers.studies.run.run_scene` reports them.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from types import ModuleType
from typing import Callable

import numpy as np

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.symbolic.profile import exact_profile
from pulsemap.solvers.models.balance_eval import BalanceRun, evaluate_balance_law, iterate_balance_map
from pulsemap.solvers.models.codeload import balance_module, force_module, map_module
from pulsemap.solvers.models.energy_quadrature import bead_force, evaluate_energy_law, iterate_energy_map, off_poles
from pulsemap.solvers.models.site_law_eval import evaluate_site_law
from pulsemap.solvers.studies.run.dressed import prepare_dressed, run_dressed
from pulsemap.solvers.models.longwave_eval import evaluate_law
from pulsemap.solvers.models.map_iteration import contact_params, eps0_ratio, iterate_map
from pulsemap.solvers.chain.equations import ForceNotFinite, chain_length_for
from pulsemap.solvers.studies.scene_chain import force_failure, make_force, out_of_range, parameter_values
from pulsemap.solvers.studies.methods import BALANCE_METHODS, DRIFT_WARN, FORCING_WARN, WIDTH_WARN
from pulsemap.solvers.studies.extent import on_contacts
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
    polynomial = pert.is_polynomial  # a scene record's fact, or sympy when the scene was parsed here
    if "map" in methods or "longwave" in methods:
        if not polynomial:  # Eq. 23 and Eq. 30 integrate R monomial by monomial (Eq. 10)
            why = (f"R = {pert.R} is not a polynomial in u, v: the map (Eq. 23) and the long-wave law (Eq. 30) "
                   "integrate R monomial by monomial (Eq. 10); the DNS and the energy balance (by quadrature) still run")
            for m in ("map", "longwave"):
                if m in methods:
                    refuse(state, m, why)
        else:
            t0 = time.perf_counter()
            try:
                mod = map_module(pert.text, pert.used_parameters, scene.exponent, choice.profile, choice.variant, site)
            except PulsemapError as exc:  # e.g. a derivation past its time bound: these two fail, the rest run
                for m in ("map", "longwave"):
                    if m in methods:
                        fail(state, m, exc)
            state.timings["derive_map"] = time.perf_counter() - t0
            wide = None if mod is None else _width_warning(mod)
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
        except PulsemapError as exc:  # the model is undefined for this R (pulsemap.symbolic.balance.BalanceError)
            for m in methods:
                if BALANCE_METHODS.get(m, ("",))[0] == quantity:
                    refuse(state, m, str(exc))
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


@dataclass(frozen=True)
class ModelInputs:
    """What the models of a run share: the generated modules, the seed and the parameter values."""

    map_module: ModuleType | None  # Eq. 23's module (map, longwave); None when neither runs
    balance: dict  # balanced quantity -> its module, or QUADRATURE
    prepared: dict  # model name -> what its Runner.prepare formed before the models ran (the dressed law)
    seed_A: float  # the amplitude at contact first_perturbed - 1 (Eq. 32)
    S0: float  # the profile's peak S(0) the seed was converted with: peak = A S0
    prm: dict  # parameter values per bead


def run_balance(state: "RunState", name: str, inputs: ModelInputs) -> dict:
    """An energy- or momentum-balance map or law (derive/balance.py)."""
    scene, out = state.scene, state.out
    pert = scene.perturbation
    seed_contact, c1 = scene.first_perturbed - 1, scene.contacts[1]
    quantity, form = BALANCE_METHODS[name]
    bmod, seed_A, prm = inputs.balance[quantity], inputs.seed_A, inputs.prm
    t0 = time.perf_counter()
    if bmod is QUADRATURE:
        br = _quadrature_energy(state, form, seed_A, prm)
    elif form == "map":
        br = iterate_balance_map(bmod, seed_A, seed_contact, c1, float(pert.eps), prm)
    elif not bmod.UNIFORM:  # coefficients varying along the chain (derive/site_law.py)
        br = evaluate_site_law(bmod, pert, "balance", seed_A, float(seed_contact), state.contacts)
        br = BalanceRun(bmod.MODEL, "law", br.contacts, br.A, br.peaks, br.ended or "ok",
                        f"{br.ended} at contact index {br.ended_at:.6g}" if br.ended else "ODE solved (LSODA, rtol 1e-11)",
                        br.ended_at, br.kind, bmod.SOURCE["profile"])
    else:
        br = evaluate_balance_law(bmod, seed_A, float(seed_contact), state.contacts, float(pert.eps), prm)
    state.timings[name] = time.perf_counter() - t0
    out["peaks"][name] = on_contacts(state.contacts, br.contacts, br.peaks)
    if br.status != "ok":
        state.warnings.append(f"{name}: {br.message}")
    return {"profile": br.profile, "status": br.status, "message": br.message, "ended_at": br.ended_at,
            "law_kind": br.law_kind, "generated": bmod.__name__ if bmod is not QUADRATURE else None}


def run_map(state: "RunState", name: str, inputs: ModelInputs) -> dict:
    """The amplitude map (Eq. 23) from the seed, with the warnings on its assumptions."""
    scene, out, warnings = state.scene, state.out, state.warnings
    mod, seed_A, prm = inputs.map_module, inputs.seed_A, inputs.prm
    seed_contact, c1 = scene.first_perturbed - 1, scene.contacts[1]
    t0 = time.perf_counter()
    mr = iterate_map(mod, seed_A, seed_contact, c1, float(scene.perturbation.eps), prm)
    state.timings[name] = time.perf_counter() - t0
    out["peaks"][name] = on_contacts(state.contacts, mr.contacts, mr.peaks)
    info = {"variant": mr.variant, "profile": mr.profile, "status": mr.status, "message": mr.message,
            "newton_fallbacks": mr.fallbacks, "engine": mr.engine, "generated": mod.__name__,
            "max_forcing_ratio": mr.max_forcing_ratio}  # |eps term| / contact term (map_iteration)
    if mr.status != "ok":
        warnings.append(f"{name}: {mr.message}")
    if mr.variant == "paper":
        drift = _eps0_drift(mod, seed_contact, c1, prm)
        info["eps0_drift"] = drift
        if drift is not None and abs(drift) > DRIFT_WARN:
            warnings.append(f"{name}: the 'paper' variant drifts by {100 * drift:+.3g} % over contacts "
                            f"{seed_contact + 1}..{c1} even at eps = 0 (erratum 5 in the docs, docs/errata.rst): "
                            "use --variant corrected or 1d")
    if mr.max_forcing_ratio is not None and mr.max_forcing_ratio > FORCING_WARN:
        k = int(np.argmax(mr.forcing_ratio > FORCING_WARN))
        warnings.append(f"{name}: at contact {int(mr.contacts[k])} the eps term of Eq. 23 exceeds "
                        f"{FORCING_WARN:g} of the contact term (max {mr.max_forcing_ratio:.3g} over the run): "
                        "outside the map's assumption eps*R << contact forces")
    return info


def run_longwave(state: "RunState", name: str, inputs: ModelInputs) -> dict:
    """The long-wave law (Eq. 30) from the seed; coefficients along the chain for a site-dependent R."""
    scene, out, mod = state.scene, state.out, inputs.map_module
    t0 = time.perf_counter()
    if not mod.UNIFORM:  # coefficients varying along the chain (derive/site_law.py)
        law = evaluate_site_law(mod, scene.perturbation, "longwave", inputs.seed_A, float(scene.first_perturbed - 1),
                                state.contacts)
    else:
        law = evaluate_law(mod, inputs.seed_A, float(scene.first_perturbed - 1), state.contacts,
                           float(scene.perturbation.eps), inputs.prm)
    state.timings[name] = time.perf_counter() - t0
    out["peaks"][name] = on_contacts(state.contacts, law.contacts, law.peaks)
    if law.ended:
        state.warnings.append(f"long-wave law: {law.ended} at contact index {law.ended_at:.4g}")
    return {"kind": law.kind, "ended_at": law.ended_at, "ended": law.ended or None, "profile": state.choice.profile}


def run_relaxed(state: "RunState", name: str, inputs: ModelInputs) -> dict:
    """The relaxed transfer map with its onset (solvers/models/relaxed.py) from the seed peak; refused
    (reported, not raised) for an R it cannot take."""
    from pulsemap.solvers.models.relaxed import RelaxedError, iterate_relaxed, model_for_scene

    scene, out = state.scene, state.out
    if scene.masses is not None:  # a kernel in the local masses, not segment runs (studies/run/chain_terms.py)
        from pulsemap.solvers.models.mass_kernel import MassKernelError
        from pulsemap.solvers.studies.run.chain_terms import mass_relaxed

        try:
            return mass_relaxed(state, name)
        except MassKernelError as exc:
            return refusal(state, name, str(exc))
    seed_contact, c1 = scene.first_perturbed - 1, scene.contacts[1]
    t0 = time.perf_counter()
    try:
        model = model_for_scene(scene, inputs.prm)
        run = iterate_relaxed(model, float(out["seed"]["peak"]), seed_contact, c1)
        # the stated accuracy is part of the build the user waits for (a table row does not ask for it)
        accuracy = model.accuracy() if state.stated_accuracy else None
    except RelaxedError as exc:
        return refusal(state, name, str(exc))
    state.timings[name] = time.perf_counter() - t0
    out["peaks"][name] = on_contacts(state.contacts, run.contacts, run.peaks)
    info = {"status": run.status, "message": run.message, "onset_contacts": model.spec.onset, "segment_runs": model.segment_runs(),
            "tables": [t.spec.R for t in model.tables.values()], "scaling_exponent": model.e}
    if accuracy is not None:
        info["bulk_accuracy_log_ratio"] = accuracy
    if model.kernels:
        info["kernel_runs"] = model.kernel_runs()
    if run.status != "ok":
        state.warnings.append(f"{name}: {run.message}")
    return info


def run_dressed_law(state: "RunState", name: str, inputs: ModelInputs) -> dict:
    """The dressed law (studies/run/dressed.py) from the seed."""
    return run_dressed(state, name, inputs.prepared.get(name), inputs.seed_A, inputs.S0)


@dataclass(frozen=True)
class Runner:
    """A row of the model table: the model's title (for every output that names it) and its runner,
    ``run(state, name, inputs)``, which writes the model's peaks and warnings into ``state`` and returns
    the model's entry of the result (without its title), and ``prepare(state)`` (None: nothing to prepare):
    the work done before any model runs (also while the chain kernels build), returning (what ``run`` finds
    in ``inputs.prepared[name]``, None) or (None, why the model is refused)."""

    title: str
    run: Callable[["RunState", str, ModelInputs], dict]
    prepare: Callable[["RunState"], tuple] | None = None


#: The model table: every reduced model a run offers (the scene schema's METHODS but the DNS), in order.
RUNNERS: dict[str, Runner] = {
    "map": Runner("amplitude map (paper Eq. 23)", run_map),
    "longwave": Runner("long-wave law (paper Eq. 30)", run_longwave),
    "energy-map": Runner("energy-balance map: E_1 A_i^(n+1) = E_1 A_(i-1)^(n+1) + W(A_(i-1))", run_balance),
    "energy-law": Runner("energy-balance law: E_1 dA^(n+1)/di = W(A)", run_balance),
    "momentum-map": Runner("momentum-balance map: p_1 A_i^(1+s) = p_1 A_(i-1)^(1+s) + J(A_(i-1))", run_balance),
    "momentum-law": Runner("momentum-balance law: p_1 dA^(1+s)/di = J(A)", run_balance),
    "relaxed": Runner("relaxed transfer map P_(k+1) = F(P_k), built from short DNS runs of the same R, with the "
                      "tabulated onset", run_relaxed),
    "dressed-law": Runner("dressed law: d ln A/di = -sum k1 x/(1 - (k2/k1) x) - sum k2_jl x_j x_l (k1, k2/k1, onset "
                          "lag, cross terms derived)", run_dressed_law, prepare_dressed),
}


def title(name: str) -> str:
    """What model ``name`` is, for outputs that name it."""
    return RUNNERS[name].title


def refusal(state: "RunState", name: str, why: str) -> dict:
    """The entry of a model refused for this R (it cannot be built for it), with its warning."""
    state.warnings.append(f"{name} refused: {why}")
    return {"refused": why}


def refuse(state: "RunState", name: str, why: str) -> None:
    """Refuse model ``name`` before the models run: its entry says why, and it does not run."""
    state.out[name] = {"model": title(name), **refusal(state, name, why)}


def failure(state: "RunState", name: str, exc: Exception) -> str:
    """One line for a model stopped by an error: the model, what went wrong and where, as far as known."""
    if isinstance(exc, ForceNotFinite):  # R itself, in a segment run of the DNS (the relaxed map)
        return force_failure(state.scene, state.scene.beads, exc, f"{name}'s segment DNS")
    if isinstance(exc, PulsemapError):
        return str(exc).splitlines()[0]
    seed = state.out.get("seed", {})
    fix = ("give a smaller --seed-peak" if state.given_seed is not None else
           "its amplitude grows without bound, or R's coefficients are too large: scale R's parameters")
    return (f"{type(exc).__name__} ({exc}) while it ran, seeded with peak {seed.get('peak', math.nan):.6g} at "
            f"contact {seed.get('contact')} ({seed.get('from', '?')}): a number left float64's range; {fix}")


def fail(state: "RunState", name: str, exc: Exception) -> None:
    """Model ``name`` failed with ``exc``: its entry says why in one line, it has no peaks."""
    why = failure(state, name, exc)
    state.out["peaks"][name] = None
    state.warnings.append(f"{name} failed: {why}")
    state.out[name] = {"model": title(name), "failed": why}


def run_model(state: "RunState", name: str, inputs: ModelInputs) -> None:
    """Run model ``name`` on its own: its entry of the result, or, when it fails (a PulsemapError, or
    numbers that leave float64), an entry saying why in one line; the other models are not touched."""
    try:
        info = RUNNERS[name].run(state, name, inputs)
    except (PulsemapError, ArithmeticError) as exc:
        fail(state, name, exc)
        return
    except ValueError as exc:  # a numerical library's words ("f(a) and f(b) must have different signs")
        if type(exc) is not ValueError:
            raise
        strong = out_of_range(state.scene)
        fail(state, name, PulsemapError(f"{name} stopped: " + (strong or f"the numerical library refused its input "
                                                                  f"({exc}): please report this scene")))
        return
    state.out[name] = {"model": title(name), **info}


def prepare_models(state: "RunState") -> dict:
    """Run every asked model's Runner.prepare: what each formed, by name; a model whose preparation is refused or
    fails gets its entry here and does not run."""
    prepared = {}
    for name in state.methods:
        prepare = RUNNERS[name].prepare if name in RUNNERS and name not in state.out else None
        if prepare is None:
            continue
        try:
            made, why = prepare(state)
        except PulsemapError as exc:  # forming the model failed (a calibration that cannot be done)
            fail(state, name, exc)
            continue
        if why is not None:
            refuse(state, name, why)
        else:
            prepared[name] = made
    return prepared


def run_models(state: "RunState") -> None:
    """Derive, seed and run every reduced model among the methods, each on its own (:func:`run_model`)."""
    mod, balance = derive_models(state)
    prepared = prepare_models(state)
    todo = [m for m in state.methods if m in RUNNERS and m not in state.out]  # not refused while deriving
    if not todo:
        return
    if not state.scene.perturbation.is_uniform:  # R or a parameter varies along the chain: real and finite at
        make_force(state.scene, state.scene.beads or chain_length_for(state.scene.contacts[1]))  # rest on each bead
    modules = [m for m in (mod, *balance.values()) if m is not None and m is not QUADRATURE]
    S0 = float(modules[0].S0 if modules else exact_profile(state.scene.exponent).S0)
    inputs = ModelInputs(mod, balance, prepared, seed_models(state, S0), S0, parameter_values(state.scene, state.scene.beads))
    for name in todo:
        run_model(state, name, inputs)


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
