"""Direct numerical simulation of the perturbed granular chain, paper Eq. 1.

    x_i'' = (x_{i-1} - x_i)_+^n - (x_i - x_{i+1})_+^n + F_i(x_i, x_i')

with free ends, all beads at rest and bead 1 given velocity v0. The state is interleaved,
y = [x_1, v_1, x_2, v_2, ...], so the Jacobian is banded (lower bandwidth 3, upper 1). The
scipy ``OdeSolver`` classes are driven step by step so that leading-edge peaks (the first local
maximum in time of delta_i = x_i - x_{i+1}) are located on each step's dense output and the run
stops as soon as the last requested contact has peaked or the pulse has died.
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from pulsemap.symbolic.profile import check_exponent
from pulsemap.solvers.chain import scaling as _scaling
from pulsemap.solvers.chain import window as _window
from pulsemap.solvers.chain.contact_force import ContactTable, check_masses
from pulsemap.solvers.chain.dns_progress import DNSProgress
from pulsemap.solvers.chain.errors import DNSInputError
from pulsemap.solvers.chain.methods import MAX_BEADS, MAX_RTOL, MIN_ATOL, MIN_RTOL, selectable  # noqa: F401  (re-exported)
from pulsemap.solvers.chain.equations import (  # noqa: F401  (re-exported: the DNS's public names)
    ENERGY_BLOWUP, ENGINES, EXPLICIT_METHODS, IMPLICIT_METHODS, METHODS, STIFFNESS_RATIO, STEPS_PER_CONTACT, Array, DNSResult,
    ForceNotFinite, IntegratorFailed, OnSiteForce, chain_length_for, choose_method, default_max_steps, default_t_max, energy,
    initial_state, largest_force, make_rhs, make_solver, ramp_atol, run_scipy)
# velocity_scale is re-exported: callers import it from pulsemap.solvers.chain.dns
from pulsemap.solvers.chain.force_table import JitForce, MonomialTable, force_data
from pulsemap.solvers.chain.front import FrontRecorder, Snapshots, check_snapshot_contacts, memo, state_at
from pulsemap.solvers.chain.launch import Launch
from pulsemap.solvers.chain.peaks import (PeakTracker, StopRules, contact_rate, real_number, scan_step,  # noqa: F401
                                          velocity_scale)
from pulsemap.solvers.chain.plan import plan, wants_force_data

if TYPE_CHECKING:  # pragma: no cover
    from pulsemap.solvers.chain.window import WindowRule, WindowSpec


# ----------------------------------------------------------------------------- the run's specs


@dataclass(frozen=True)
class Chain:
    """The chain of paper Eq. 1 and how it starts: ``beads`` N, the contact ``exponent`` n, bead 1's
    impact ``velocity`` v0, the on-site ``force`` F_i (an OnSiteForce; None: the bare chain),
    ``launch`` (chain/launch.Launch): an exact solitary wave instead of the impact (None: the impact),
    the contact law's term ``contact`` eps_c P_k(d, w) (a contact_force.ContactTable; None: Hertz alone)
    and the bead ``masses`` (N values; None: all 1).
    One-line TypeError/ValueError naming the field on bad input."""

    beads: int
    exponent: float
    velocity: float
    force: OnSiteForce | None = None
    launch: Launch | None = None
    contact: ContactTable | None = None
    masses: "Array | None" = None

    def __post_init__(self) -> None:
        beads, exponent, velocity = self.beads, self.exponent, self.velocity
        real_number(exponent, "exponent")
        real_number(velocity, "velocity")
        if isinstance(beads, (str, bytes)):
            raise TypeError(f"beads must be an integer, got {type(beads).__name__} {beads!r}")
        if isinstance(beads, bool) or not isinstance(beads, (int, np.integer)) or beads < 2:
            raise DNSInputError(f"beads must be an integer >= 2, got {beads!r}; use chain_length_for(last_contact)")
        if beads > MAX_BEADS:
            raise DNSInputError(f"beads = {beads} is beyond the supported {MAX_BEADS}: use a shorter chain")
        if not math.isfinite(exponent) or exponent <= 1.0:
            raise DNSInputError(f"exponent must be a finite number > 1 (Hertz: 1.5), got {exponent!r}")
        check_exponent(float(exponent))  # the profile's supported range: beyond it the wave is not float64
        if not math.isfinite(velocity):
            raise DNSInputError(f"velocity must be finite, got {velocity!r}")
        if velocity <= 0.0:
            raise DNSInputError(f"velocity must be > 0 (bead 1 pushes into the chain), got {velocity!r}")
        _scaling.check_velocity_range(float(velocity))
        if self.force is not None and not isinstance(self.force, OnSiteForce):
            raise TypeError(f"force must be an OnSiteForce or None, got {type(self.force).__name__}")
        if self.launch is not None and not isinstance(self.launch, Launch):
            raise TypeError(f"launch must be a solvers.chain.launch.Launch or None, got {type(self.launch).__name__}")
        if self.contact is not None and not isinstance(self.contact, ContactTable):
            raise TypeError(f"contact must be a solvers.chain.contact_force.ContactTable or None, "
                            f"got {type(self.contact).__name__}")
        object.__setattr__(self, "masses", check_masses(self.masses, int(beads)))
        if self.launch is not None and self.masses is not None:
            raise DNSInputError("a launched solitary wave starts a chain of unit masses: give masses=None, or start "
                                 "from the impact")
        object.__setattr__(self, "beads", int(beads))
        object.__setattr__(self, "exponent", float(exponent))
        object.__setattr__(self, "velocity", float(velocity))


@dataclass(frozen=True)
class Integrator:
    """How Eq. 1 is integrated: ``method`` (equations.METHODS; 'auto' lets plan() choose), the
    tolerances ``rtol`` and ``atol``, and the ``engine`` (equations.ENGINES: 'compiled' where it
    applies, else scipy; 'scipy' always scipy). One-line TypeError/ValueError naming the field."""

    method: str = "auto"
    rtol: float = 1e-10
    atol: float = 1e-12
    engine: str = "compiled"

    def __post_init__(self) -> None:
        method, rtol, atol = self.method, self.rtol, self.atol
        real_number(rtol, "rtol")
        real_number(atol, "atol")
        known = selectable()
        if not isinstance(method, str):
            raise TypeError(f"method must be a string ({', '.join(known)}), got {type(method).__name__}")
        if method not in known:
            raise DNSInputError(f"unknown method {method!r}; choose one of {', '.join(known)}")
        if not (math.isfinite(rtol) and rtol > 0.0):
            raise DNSInputError(f"rtol must be a finite number > 0, got {rtol!r}")
        if rtol < MIN_RTOL:
            raise DNSInputError(f"rtol = {rtol:g} is below what float64 can deliver: give rtol >= {MIN_RTOL:.2g} "
                                 "(100 x machine epsilon)")
        if rtol >= MAX_RTOL:
            raise DNSInputError(f"rtol = {rtol:g} is beyond the usable range {MIN_RTOL:.2g} <= rtol < {MAX_RTOL:g}: "
                                 "a relative tolerance of 1 or more keeps no digit of the peaks")
        if not (math.isfinite(atol) and atol > 0.0):
            raise DNSInputError(f"atol must be a finite number > 0, got {atol!r}")
        if atol < MIN_ATOL:
            raise DNSInputError(f"atol = {atol:g} is below what the error norm can use: give atol >= {MIN_ATOL:g} "
                                 "(the norm squares error/atol, which leaves float64 below ~1e-154)")
        if self.engine not in ENGINES:
            raise DNSInputError(f"unknown engine {self.engine!r}; choose one of {', '.join(ENGINES)}")


def check_run(chain: Chain, contacts: tuple[int, int], stop: StopRules) -> tuple[int, int]:
    """Check what simulate() takes beyond its specs' own checks (each option object checks its fields when
    made): the contact range against the chain; return the range. One-line ValueErrors (TypeErrors for a
    value of the wrong type), each naming the argument."""
    if not isinstance(chain, Chain):
        raise TypeError(f"chain must be a Chain (solvers.chain.dns), got {type(chain).__name__}")
    if not isinstance(stop, StopRules):
        raise TypeError(f"stop must be a StopRules (solvers.chain.peaks), got {type(stop).__name__}")
    beads = chain.beads
    try:
        first, last = (int(c) for c in contacts)
    except (TypeError, ValueError):
        raise DNSInputError(f"contacts must be a pair (first, last) of integers, got {contacts!r}") from None
    if (first, last) != tuple(contacts):
        raise DNSInputError(f"contacts must be integers, got {contacts!r}")
    if not 1 <= first <= last <= beads - 1:
        raise DNSInputError(
            f"contacts {contacts!r} must satisfy 1 <= first <= last <= beads-1 = {beads - 1}; "
            f"fix the range or use beads=chain_length_for({last})"
        )
    return first, last


# ----------------------------------------------------------------------------- the run


def _energies(chain: Chain, res: DNSResult) -> DNSResult:
    """What a run's energies say, decided once for every engine (each reports its drift where its on-site force
    conserves energy). A contact term does work (dH/dt = -eps_c sum H P w), so ``energy_drift`` is None with one.
    A moving window knows the whole chain's energy only for the Hertz chain of unit masses without R: the beads
    it dropped keep what they carried then (their drift is the run's accuracy check); with R they go on gaining or
    losing energy out of sight (docs/dns.rst), so ``total_energy`` is None; with masses the beads behind a mass
    step keep moving and trade energy with the window through its coasting bead while the peaks stay exact
    (docs/contact.rst), so ``energy_drift`` is None too. The pulse's energy (beads k-8..k+8) stays."""
    full = res.mode == "full"
    drift = chain.contact is None and (full or chain.masses is None)
    total = full or (chain.force is None and chain.contact is None and chain.masses is None)
    if drift and total:
        return res
    return replace(res, energy_drift=res.energy_drift if drift else None,
                   total_energy=res.total_energy if total else None)


def simulate(
    chain: Chain,
    contacts: tuple[int, int],
    *,
    integrator: Integrator = Integrator(),
    stop: StopRules = StopRules(),
    window: "WindowSpec | int | str | WindowRule | None" = None,
    snapshots: Snapshots = Snapshots(),
    progress: bool = False,
) -> DNSResult:
    """Integrate Eq. 1 for ``chain`` (a Chain: N, n, v0, F_i, start) and return the leading-edge
    peaks of contacts[0]..contacts[1].

    ``chain.launch`` (solvers/chain/launch.py): start from an exact solitary wave of amplitude A
    centred on a contact instead of the impact v0 on bead 1 (default None: the impact). With a
    launch, ``chain.velocity`` is not used: the wave's velocity scale A^((n+1)/2) takes its place in
    the thresholds, and only contacts after the centre are tracked.

    ``window=None`` (default) integrates the whole chain. ``window=WindowSpec(...)``
    (solvers/chain/window.py) integrates only a moving window of beads around the leading edge:
    its ``size`` 'auto' is sized so that the window costs less than its ``accuracy`` in relative
    peak error (default None: the looser of rtol and 1e-8; the rule's calibration: docs/dns.rst),
    an int gives the window's width in beads, a ``WindowRule`` its full geometry; its ``engine``
    is the scipy engine's window integrator ("auto": Hairer's Fortran DOP853/DOPRI5 for those
    methods, else the scipy OdeSolver; "fortran"; "scipy"). A size alone (``window="auto"``, an
    int, a WindowRule) stands for WindowSpec(size). The windowed cost per contact does not grow
    with N. Its ``energy_drift`` counts the energy carried out by dropped beads.

    All contacts 1..last are tracked (``stop``, a peaks.StopRules: each one's acceptance threshold
    is ``peak_fraction`` times the previous contact's peak; contact 1 uses the scale
    v0^(2/(n+1))). The run stops when the last contact has peaked, when the pulse dies (a peak
    below ``death_fraction`` times the first requested contact's peak), when no new contact peaks
    within ``stall_factor`` times the last inter-peak delay, at ``t_max``, or when the state becomes
    non-finite or the energy grows beyond 1e6 times its initial value. A contact whose first
    maximum exceeds ``overtake_factor`` times the previous contact's no longer carries the
    primary pulse (the wake overtook the front): the run stops there too. ``max_steps``
    (default ``default_max_steps(last, rtol)``) bounds the accepted steps, so no run can hang.
    Whatever stops the run, the peaks measured before it are returned (never NaN for a
    contact marked alive).

    As each requested contact peaks, the pulse's and the chain's energy are recorded
    (front.py); ``snapshots`` (a front.Snapshots): contacts at whose peak time the strains of
    contacts k - span[0] .. k + span[1] are kept.

    ``integrator`` (an Integrator: method, rtol, atol, engine): ``engine="compiled"`` (default)
    runs chain/compiled.py (numba Dormand-Prince 5(4) for method 'auto' or 'RK45', numba DOP853
    for 'DOP853' (order 8: cheaper on a smooth, damped pulse, dearer where the wake keeps reopening
    contacts), the force as a monomial table or, for a non-polynomial R (a non-smooth one as the ramp
    of derive/codegen_force.py), a generated numba function; Rodas4 with the exact Jacobian when 'auto'
    finds the force stiff) where it applies,
    else the scipy engine; ``engine="scipy"`` always the scipy engine. The result's
    ``engine_reason`` says which and why.
    """
    if not isinstance(integrator, Integrator):
        raise TypeError(f"integrator must be an Integrator (solvers.chain.dns), got {type(integrator).__name__}")
    if not isinstance(snapshots, Snapshots):
        raise TypeError(f"snapshots must be a Snapshots (solvers.chain.front), got {type(snapshots).__name__}")
    if not isinstance(progress, bool):
        raise TypeError(f"progress must be True or False, got {type(progress).__name__}")
    first, last = check_run(chain, contacts, stop)
    beads, exponent, velocity, force, launch = chain.beads, chain.exponent, chain.velocity, chain.force, chain.launch
    integrator = replace(integrator, atol=ramp_atol(chain.force, integrator.atol))  # a ramp's cap (equations.py)
    rtol, atol = integrator.rtol, integrator.atol
    contact, masses = chain.contact, chain.masses
    if launch is None and _scaling.needs_rescaling(velocity):  # a rescaled run at v0 = 1 (solvers/chain/scaling.py)
        _scaling.check_force_range(force, exponent, velocity, beads)
        scale = _scaling.Scaling(exponent, velocity)
        unit = simulate(
            replace(chain, velocity=1.0, force=scale.force(force), contact=scale.contact(contact)), (first, last),
            integrator=integrator,
            stop=replace(stop, t_max=None if stop.t_max is None else float(stop.t_max) / scale.tau),
            window=window, snapshots=snapshots, progress=progress)
        return scale.result(unit)
    if launch is not None:
        launch.check(exponent, first, beads)
        velocity = launch.velocity_scale(exponent)
    front = FrontRecorder(first, last, exponent, check_snapshot_contacts(snapshots.contacts, first, last),
                          snapshots.span)
    data, how = _planned(chain, integrator, window, bool(snapshots.contacts))
    chosen = how.method
    t_limit = default_t_max(last, velocity, exponent) if stop.t_max is None else float(stop.t_max)
    budget = default_max_steps(last, rtol) if stop.max_steps is None else int(stop.max_steps)
    rules = replace(stop, t_max=t_limit, max_steps=budget)
    if how.engine == "compiled":
        from pulsemap.solvers.chain import compiled  # numba: imported only when used

        try:
            res = compiled.simulate_compiled(
                chain, (first, last), data, how, integrator, rules, progress=progress,
                failure_note=lambda lo, y: largest_force(_window.restrict_force(force, beads, lo, lo + y.size // 2), y, lo))
        except ForceNotFinite as exc:
            raise _locate(force, beads, exc) from None
        return _energies(chain, res)
    terms = (contact, masses)
    if how.rule is not None:
        with np.errstate(all="ignore"):  # a non-finite force raises ForceNotFinite (models/onsite.py), unprinted
            res = _window.simulate_windowed(chain, (first, last), how, integrator, rules, progress=progress, front=front)
        return _energies(chain, replace(res, engine="scipy", engine_reason=how.reason))
    y0 = initial_state(beads, velocity) if launch is None else launch.state(exponent, beads)
    e0 = energy(y0[0::2], y0[1::2], exponent, masses)

    wall0 = _time.perf_counter()
    solver = make_solver(chosen, beads, exponent, force, y0, t_limit, rtol, atol, terms=terms)
    track = PeakTracker.start(first, last, velocity, exponent, rules,
                              next_contact=1 if launch is None else launch.centre + 1, method=chosen)
    drift = 0.0
    report = DNSProgress("dns", last, enabled=progress)

    def on_step(t_old: float, y_old: Array, t_new: float, y_new: Array, dense_factory) -> bool:
        """Bookkeeping after one accepted step (energy every step); True stops the run."""
        nonlocal drift
        e = energy(y_new[0::2], y_new[1::2], exponent, masses)
        if track.check_state(t_new, e, e0, ENERGY_BLOWUP):
            return True
        drift = max(drift, abs(e - e0) / e0)
        dense = memo(dense_factory)
        found = scan_step(y_old, y_new, t_old, t_new, dense, track.next_contact, last, track.threshold, stop.peak_fraction)
        track.record(found)
        if found:
            front.record(found, state_at(dense()))
        if track.check_progress(t_new, t_limit, budget):
            return True
        report.update(t_new, track.next_contact - 1, f"{chosen}, {solver.nfev} RHS evaluations")
        return False

    try:
        with np.errstate(all="ignore"):  # a non-finite force raises ForceNotFinite (models/onsite.py), unprinted
            run_scipy(solver, on_step)
    except RuntimeError as err:
        track.reason = str(err) + (largest_force(force, err.y) if isinstance(err, IntegratorFailed) else "")
    track.reason = track.reason or f"t_max reached (t={solver.t:.6g}, next contact {track.next_contact})"

    wall = _time.perf_counter() - wall0
    return _energies(chain, DNSResult.tracked(
        track, front, method=chosen, rtol=float(rtol), atol=float(atol), beads=beads, nfev=int(solver.nfev),
        njev=int(getattr(solver, "njev", 0)), wall_time_s=wall, energy_drift=drift if force is None else None,
        exponent=exponent, velocity=velocity, t_end=float(solver.t), window_beads=beads, energy_initial=e0,
        engine="scipy", engine_reason=how.reason,
    ))


def compiled_kernel_of(chain: Chain, *, integrator: Integrator = Integrator(),
                       window: "WindowSpec | int | str | WindowRule | None" = None) -> tuple[str, str] | None:
    """The compiled kernel simulate runs for ``chain`` with these settings, as (method, force form:
    "dense" or "table", compiled_aot.py), or None where the scipy engine or a generated numba force runs.
    Nothing is integrated: a command asks it to build the kernels ahead on another core."""
    from pulsemap.solvers.chain.compiled_aot import FORM_OF_NDIM

    if chain.launch is None and _scaling.needs_rescaling(chain.velocity):  # simulate's rescaled run at v0 = 1
        chain = replace(chain, velocity=1.0, force=_scaling.Scaling(chain.exponent, chain.velocity).force(chain.force))
    data, how = _planned(chain, integrator, window, False)
    if how.engine != "compiled" or isinstance(data, JitForce) or chain.contact is not None or chain.masses is not None:
        return None
    return how.method, FORM_OF_NDIM[(MonomialTable.zero() if data is None else data).kernel_args[1].ndim]


def _planned(chain: Chain, integrator: Integrator, window, snapshots: bool):
    """(the force as the compiled kernels take it, or None; plan()'s Plan) of a run of ``chain`` at its own
    velocity (simulate rescales first where it must): the velocity scale is the launch's where there is one."""
    velocity = chain.velocity if chain.launch is None else chain.launch.velocity_scale(chain.exponent)
    method, engine = integrator.method, integrator.engine
    data, force_reason = force_data(chain.force) if wants_force_data(engine, method, snapshots) else (None, "")
    return data, plan(engine=engine, method=method, force=chain.force, velocity=velocity, exponent=chain.exponent,
                      rtol=integrator.rtol, window=window, snapshots=snapshots, force_reason=force_reason,
                      damping=0.0 if chain.contact is None else
                      chain.contact.damping(chain.exponent, velocity_scale(velocity, chain.exponent)),
                      mass_step=_window.largest_mass_step(chain.masses))


def _locate(force: OnSiteForce | None, beads: int, exc: ForceNotFinite) -> ForceNotFinite:
    """The bead and time of a compiled run's non-finite force: F (and its slopes) on the window along
    the failed step's line y + c h f, c = 0 .. 1, at the first c where one is not finite; ``exc``
    itself when the line misses it (the stages leave it by O(h^2))."""
    if exc.state is None or force is None:
        return exc
    lo, y, f, h = exc.state
    on = _window.restrict_force(force, beads, lo, lo + y.size // 2)
    for c in np.linspace(0.0, 1.0, 65):
        ys = y + c * h * f
        for fn in (on.force, on.dforce_dx, on.dforce_dv):
            try:
                if fn is not None:
                    with np.errstate(all="ignore"):
                        fn(ys[0::2], ys[1::2])
            except ForceNotFinite as found:
                return found.at(exc.t + c * h)
    return exc
