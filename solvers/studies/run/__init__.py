"""Run a scene: DNS, map and long-wave law side by side, with errors and timings (docs/design.rst, "The result of a run").

Only what the scene asks for is computed: no DNS unless "dns" is among its methods (the map is
then seeded from v0 through kappa_n), no long-wave law for a site-dependent perturbation, and a
chain only as long as the contacts need. In a run with the DNS, the map and the law start from
the DNS peak at the last unperturbed contact (first_perturbed - 1), converted by Eq. 32.

:func:`run_scene` is four steps: lay out the result (:func:`start_run`; the choices were checked where
they entered, :func:`pulsemap.solvers.api.checks.run_choices`), the DNS or a reused one
(:func:`run_dns`, :func:`reuse_dns_run`), the reduced models
(:func:`pulsemap.solvers.studies.run.models.run_models`) and the errors against the DNS
(:func:`compare_with_dns`). The chain is :mod:`~pulsemap.solvers.studies.scene_chain`'s, the error
measures :mod:`~pulsemap.solvers.studies.errors`, the outputs
:mod:`~pulsemap.solvers.studies.run.report`.
"""

from __future__ import annotations

import math
import numbers
import time
from typing import Sequence

import numpy as np

from pulsemap.symbolic.provenance import provenance
from pulsemap.solvers import __version__
from pulsemap.solvers.chain.front import Snapshots
from pulsemap.solvers.chain.dns import compiled_kernel_of, simulate
from pulsemap.solvers.chain.window import full_chain_because, largest_mass_step
from pulsemap.solvers.data.scene import METHODS, PROFILES, VARIANTS, Scene
from pulsemap.solvers.studies.errors import model_error
from pulsemap.solvers.studies.scene_chain import force_failure, scene_chain
from pulsemap.solvers.studies.methods import EPS_WARN, MODELS, Choice, RunError
from pulsemap.solvers.studies.run import chain_terms, kinds
from pulsemap.solvers.studies.extent import (contact_slots, dns_integrator, dns_span, dns_window_of, listed,
                                            on_contacts)
from pulsemap.solvers.studies.run.state import RunState

__all__ = ["derive_models", "derive_while_kernels_build", "dns_kernel", "run_scene"]


def start_run(scene: Scene, methods: Sequence[str] | None, profile: str | None, variant: str | None,
              seed_peak: float | None, snapshots: Sequence[int] = ()) -> RunState:
    """Lay out the result of a run (None: the scene's methods, profile, variant).

    Names and ranges were checked where the input entered (``pulsemap.run``, the CLI:
    api/checks.run_choices): asserted here."""
    assert isinstance(scene, Scene), type(scene)
    methods = tuple(scene.methods) if methods is None else tuple(methods)
    assert methods and all(m in METHODS for m in methods), methods
    choice = Choice(profile or scene.profile, variant or scene.variant)
    assert choice.profile in PROFILES and choice.variant in VARIANTS, choice
    assert seed_peak is None or (isinstance(seed_peak, numbers.Real) and math.isfinite(seed_peak) and seed_peak > 0), seed_peak
    c0, c1 = scene.contacts
    contacts = list(range(c0, c1 + 1))
    out: dict = {
        "pulsemap_version": __version__,
        "provenance": provenance(),  # package and library versions (derive/provenance.py)
        "scene": scene.as_dict(),
        "choices": {"profile": choice.profile, "variant": choice.variant, "methods": list(methods)},
        "contacts": contacts,
        "peaks": {"dns": None, **{m: None for m in MODELS}},
        "errors": {},
        "timings_s": {},
        "warnings": [],
    }
    eps = scene.perturbation.eps
    if eps > EPS_WARN and any(m in MODELS for m in methods):
        out["warnings"].append(f"eps = {eps:g} is not small: the reduced models assume eps << 1")
    if "map" in methods and choice.variant == "paper" and not scene.perturbation.acts:
        out["warnings"].append("map: the paper's Eq. 23 drifts even without perturbation (A shrinks by "
                               "(1 + f7/(2 f1))^(-1/P) per contact, docs/errata.rst item 5); --variant corrected "
                               "or 1d keeps A constant")
    assert all(isinstance(c, int) and c0 <= c <= c1 for c in snapshots) and (not snapshots or "dns" in methods), snapshots
    refused = kinds.refusals(scene, methods)
    if refused:
        from pulsemap.solvers.studies.run.models import title  # the model table (loads the models' modules)

        for m, why in refused.items():
            out[m] = {"model": title(m), "refused": why}
            out["warnings"].append(f"{m} refused: {why}")
    methods = tuple(m for m in methods if m not in refused)
    return RunState(scene, methods, choice, out, given_seed=seed_peak, contacts=contacts,
                    snapshots=tuple(sorted(set(snapshots))))


def dns_kernel(scene: Scene) -> tuple[str, str] | None:
    """The compiled kernel (method, force form) the scene's DNS runs on (chain/dns.compiled_kernel_of), or None."""
    beads, _ = dns_span(scene)
    return compiled_kernel_of(scene_chain(scene, beads),
                              integrator=dns_integrator(scene.dns), window=dns_window_of(scene, "scene"))


def derive_models(scene: Scene, methods: Sequence[str], profile: str | None = None,
                  variant: str | None = None) -> None:
    """Derive the reduced models ``methods`` of ``scene`` into the caches, running none of them (no DNS
    either): the work a command does on one core while the chain kernels build on another."""
    from pulsemap.solvers.studies.run import models  # the models' modules load when a model is derived

    state = start_run(scene, methods, profile, variant, None)
    models.derive_models(state)
    models.prepare_models(state)  # e.g. forms the dressed law into the caches (a refusal is the run's to report)


def _ahead(step, *args):
    """``step(*args)``, or None where it raises: work done ahead, which the run that does it again reports."""
    try:
        return step(*args)
    except Exception:  # noqa: BLE001 - reported by the run that meets it
        return None


def derive_while_kernels_build(jobs: Sequence[tuple], say=None, timings: dict | None = None) -> bool:
    """Build the chain kernels the DNS of the jobs' scenes need, each in a child process started as soon as a
    scene needs it (chain/compiled_aot.build_in_background), while this process derives the jobs' models
    ``(scene, methods, profile, variant)`` into the caches; then wait for the builds. From empty caches both
    take seconds, and the runs then find both ready. False (and nothing done) when no kernel is missing;
    ``say(text)``: told what happens when something does; ``timings``: gets ``dns_build``, the wall seconds from
    the first build's start to the last one's end (the real build time, on another core)."""
    from pulsemap.solvers.chain.compiled_aot import build_in_background

    children, asked, scenes = [], set(), list(dict.fromkeys(job[0] for job in jobs))
    started = time.perf_counter()
    try:
        for scene in scenes:
            kernel = _ahead(dns_kernel, scene)
            if kernel is not None and kernel not in asked:
                asked.add(kernel)
                child = build_in_background([kernel])
                children += [child] if child is not None else []
        if not children:
            return False
        if say is not None:
            say(f"deriving the models of {len(scenes)} scene{'s' * (len(scenes) != 1)} while the chain kernels build")
        for scene, methods, profile, variant in jobs:
            if any(m != "dns" for m in methods):
                _ahead(derive_models, scene, [m for m in methods if m != "dns"], profile, variant)
        import scipy.integrate, scipy.interpolate, scipy.optimize  # noqa: E401, F401 - the models' scipy, loaded meanwhile
        return True
    finally:
        for child in children:
            child.wait()
        if children and timings is not None:
            timings["dns_build"] = time.perf_counter() - started


def run_dns(state: RunState, progress: bool, dns_window: "int | str | None") -> None:
    """The full equations of motion over the contacts (chain/dns.py) on the moving window unless the
    scene or the caller asks for the full chain; its peak at first_perturbed - 1 becomes the models' seed."""
    scene, out, contacts = state.scene, state.out, state.contacts
    beads, span = dns_span(scene)
    t0 = time.perf_counter()
    chain = scene_chain(scene, beads)
    state.timings["derive_force"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    window = dns_window_of(scene, dns_window)
    try:
        res = simulate(chain, span, integrator=dns_integrator(scene.dns),
                       snapshots=Snapshots([c for c in state.snapshots if span[0] <= c <= span[1]]),
                       progress=progress, window=window)
    except ArithmeticError as exc:  # R not finite (or not real) where the chain went
        raise RunError(force_failure(scene, beads, exc, "DNS")) from None
    if res.build_s:  # this run built the ahead-of-time kernel (no other process did it ahead)
        state.timings["dns_build"] = res.build_s
    state.timings["dns_compile"] = res.compile_s - res.build_s  # compiling or loading the kernel, apart from integrating
    state.timings["dns"] = time.perf_counter() - t0 - res.compile_s
    because = full_chain_because(largest_mass_step(chain.masses)) if window == "auto" else ""  # as simulate's plan
    seed_contact = scene.first_perturbed - 1
    first, last = min(contacts[0], seed_contact), max(contacts[-1], seed_contact)
    slots = contact_slots(np.arange(first, last + 1), res.contacts)  # once for the peaks, the seed and front_outputs
    peaks = at_contacts(res.peaks, slots, res.alive)
    dns_peaks = peaks[contacts[0] - first: contacts[-1] - first + 1]
    dns_alive = [p is not None for p in dns_peaks]
    state.dns_peaks, state.dns_alive = dns_peaks, dns_alive
    out["peaks"]["dns"] = dns_peaks
    out["dns"] = {
        "method": res.method, "rtol": res.rtol, "atol": res.atol, "beads": res.beads, "mode": res.mode,
        **({"full_chain_because": because} if because else {}),
        "window_beads": int(res.window_beads),
        **({"window_behind": int(res.window_rule.behind)} if res.window_rule is not None else {}),
        "engine": res.engine, "engine_reason": res.engine_reason,
        "stop_reason": res.stop_reason, "nfev": int(res.nfev),
        "alive": dns_alive,
        "live_contacts": [c for c, a in zip(contacts, dns_alive) if a],
    }
    found, index = slots
    reported = slice(contacts[0] - first, contacts[-1] - first + 1)
    out["dns"].update(front_outputs(res, (found[reported], index[reported]), dns_alive))
    if res.velocity_peaks is not None:  # a chain with masses: each bead's first velocity maximum
        beads = [c for c in contacts if c <= res.velocity_peaks.size]
        out["dns"]["velocity_peaks"] = {"beads": beads, "peaks": on_contacts(
            beads, range(1, res.velocity_peaks.size + 1), res.velocity_peaks)}
    if not all(dns_alive):
        dead = [c for c, a in zip(contacts, dns_alive) if not a]
        state.warnings.append(f"DNS: no live primary pulse at contacts {dead[0]}..{dead[-1]} ({res.stop_reason})")
    dns_seed = peaks[seed_contact - first]
    if dns_seed is not None:
        state.seed_peak = dns_seed
        out["dns"]["seed_peak"] = dns_seed  # peak at first_perturbed - 1, seeds map and law


def at_contacts(values, slots: tuple, alive=None) -> list:
    """A DNS measure (an array over ``res.contacts``) at the contacts ``slots`` locates
    (studies/points.contact_slots): None where it was not measured, is not finite or, with ``alive``
    (over ``res.contacts`` too), the primary pulse was not alive."""
    found, index = slots
    if values is None:
        return [None] * found.size
    got = np.asarray(values, dtype=float)
    if not got.size:
        return [None] * found.size
    keep = found & np.isfinite(got[index])
    if alive is not None:
        keep &= np.asarray(alive, dtype=bool)[index]
    return listed(got, keep, index)


def front_outputs(res, slots: tuple, alive: list[bool]) -> dict:
    """What the DNS measured at each reported contact (``slots``: where they are in ``res.contacts``)
    besides the peak (chain/front.py): arrival time of the peak, pulse speed (contacts per unit time),
    energy of the pulse and of the chain; None where the primary pulse is not ``alive``. The energy
    drift is the accuracy check of a chain without R (None with R: its energy is not conserved)."""
    found, index = slots
    live = (found & np.asarray(alive, dtype=bool), index)

    def per_contact(values) -> list:
        return at_contacts(values, live)

    return {
        "arrival_times": per_contact(res.peak_times),
        "speed": per_contact(res.speed),
        "pulse_energy": per_contact(res.pulse_energy),
        "total_energy": per_contact(res.total_energy),
        "energy_initial": res.energy_initial,
        "energy_drift": res.energy_drift,
        "snapshots": [s.as_dict() for s in res.snapshots],
    }


def reuse_dns_run(state: RunState, reuse_dns: dict) -> None:
    """Take the DNS peaks and seed of an earlier run of the same scene and contacts."""
    if reuse_dns.get("contacts") != state.contacts or reuse_dns["peaks"].get("dns") is None:
        raise RunError("reuse_dns must be a DNS run of the same scene and contacts")
    state.dns_peaks = reuse_dns["peaks"]["dns"]
    state.dns_alive = reuse_dns["dns"]["alive"]
    state.out["peaks"]["dns"] = state.dns_peaks
    state.out["dns"] = {**reuse_dns["dns"], "reused": True}
    state.seed_peak = reuse_dns["dns"].get("seed_peak")


def compare_with_dns(state: RunState) -> None:
    """The error of every model that has peaks against the DNS peaks (studies/errors.py: percent over
    the live range, the one definition every output reports)."""
    if state.dns_peaks is None:
        return
    out = state.out
    seed_peak = out.get("seed", {}).get("peak")
    for name in MODELS:
        if out["peaks"][name] is not None:
            out["errors"][name] = model_error(state.contacts, state.dns_peaks, out["peaks"][name],
                                              state.scene.first_perturbed - 1, seed_peak)


def run_scene(
    scene: Scene,
    *,
    methods: Sequence[str] | None = None,
    profile: str | None = None,
    variant: str | None = None,
    progress: bool = False,
    dns_window: "int | str | None" = "scene",
    reuse_dns: dict | None = None,
    seed_peak: float | None = None,
    snapshots: Sequence[int] = (),
    stated_accuracy: bool = True,
) -> dict:
    """Run ``scene`` and return the result as JSON-serialisable data (docs/design.rst, "The result of a run").

    ``reuse_dns``: the result of an earlier run of the same scene with the DNS; its peaks (and
    its seed) are used instead of running the DNS again (for comparing profiles and variants).
    ``seed_peak``: a measured peak at contact first_perturbed - 1 to seed map and law with
    (converted by Eq. 32), instead of the DNS peak or v0 through kappa_n. ``snapshots``: contacts at
    whose peak time the DNS keeps the strains delta_j, j = k-12..k+4 (result["dns"]["snapshots"]).
    ``dns_window``: "scene" (default: the scene's [dns] mode, the moving window unless it says
    "full"), "auto" (the moving window), an int (its width in beads) or None (the full chain).
    ``stated_accuracy``: False leaves out the relaxed map's ``bulk_accuracy_log_ratio`` (leave-one-run-out
    spline fits: seconds from an empty cache), for callers that only compare peaks (``pulsemap table``).
    """
    assert isinstance(progress, bool), progress  # callers validated their input: pulsemap.run, the CLI
    assert dns_window in ("scene", "auto", None) or (isinstance(dns_window, int) and not isinstance(dns_window, bool)), dns_window
    assert reuse_dns is None or (isinstance(reuse_dns, dict) and isinstance(reuse_dns.get("peaks"), dict)), reuse_dns
    assert isinstance(stated_accuracy, bool), stated_accuracy
    state = start_run(scene, methods, profile, variant, seed_peak, snapshots)
    state.stated_accuracy = stated_accuracy
    if "dns" in state.methods:
        if any(m != "dns" for m in state.methods):  # models to derive while a missing kernel builds
            derive_while_kernels_build([(scene, state.methods, profile, variant)], timings=state.timings)
        run_dns(state, progress, dns_window)
    if reuse_dns is not None and "dns" not in state.methods:
        reuse_dns_run(state, reuse_dns)
    if chain_terms.has_chain_terms(scene):  # a contact law's term or masses: the energy law of its own module
        chain_terms.run_chain_term_models(state)
        state.methods = tuple(m for m in state.methods if m not in chain_terms.CHAIN_TERM_MODELS)
    if any(m != "dns" for m in state.methods):
        from pulsemap.solvers.studies.run.models import run_models  # the models' modules load when a model runs

        run_models(state)
    compare_with_dns(state)
    return state.out
