"""Compiled (numba) moving-window DNS of paper Eq. 1: the engine behind ``Integrator(engine="compiled")``.

    x_i'' = (x_{i-1} - x_i)_+^n - (x_i - x_{i+1})_+^n + F_i(x_i, x_i')       (paper Eq. 1)

Dormand-Prince 5(4) with PI step control and dense output (solvers/chain/compiled_kernel.py; DOP853,
solvers/chain/compiled_dop853.py, when asked for by name), or for a stiff force (method 'auto', above
plan.COMPILED_STIFFNESS_RATIO x the contact rate) Rodas4 with the exact banded Jacobian (solvers/chain/compiled_stiff.py); the
same leading-edge peaks (root of delta' on the dense output) and the same stop rules and messages
as the scipy engines (solvers/peaks.PeakTracker), and the same DNSResult.

Window (``rule``, a solvers.window.WindowRule): exactly ``rule.behind`` beads are kept behind
the last peaked contact (the last dropped bead coasts, ``rule.boundary``), the calibrated
accuracy rule of window.rule_for_accuracy; ahead, the window ends at the first bead at rest to
``rule.threshold`` (relative to v0^(2/(n+1)) and v0), followed by a wall at rest: a bead is added
as soon as the last one moves. ``rule=None`` is the full chain: nothing is dropped and the
window grows ahead as soon as the last bead moves at all (beads exactly at rest feel no force,
so this is the full chain's dynamics). The error norm is the RMS over the integrated beads.
F enters as data (solvers/chain/force_table.py: a monomial table, its dense form, or a generated
numba force for a non-polynomial R).
"""

from __future__ import annotations

import math
import time as _time
import warnings
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from pulsemap.solvers.chain import compiled_aot
from pulsemap.solvers.chain import compiled_layout as K
from pulsemap.solvers.chain.contact_force import kernel_terms
from pulsemap.solvers.chain.equations import ENERGY_BLOWUP, DNSResult, ForceNotFinite, energy
from pulsemap.solvers.chain.force_table import JitForce, MonomialTable
from pulsemap.solvers.chain.peaks import (PeakTracker, StopRules, contact_rate, first_threshold, primary_pulse_lost,
                                          velocity_scale)
from pulsemap.solvers.chain import methods
from pulsemap.solvers.chain.plan import METHOD, explicit_reason

if TYPE_CHECKING:  # pragma: no cover
    from pulsemap.solvers.chain.dns import Chain, Integrator
    from pulsemap.solvers.chain.plan import Plan

Array = np.ndarray
ENERGY_EVERY = 4  # blow-up guard and energy drift every this many steps (as solvers/window.py)
DELAY_FACTOR = 2.0  # peaks.primary_pulse_lost's default
ROOM = 96  # initial buffer beyond ``behind`` (grown on demand)
PAUSE_STEPS = 20_000  # accepted steps between progress checks (~2-20 ms of kernel time)


def _reason(code: int, track: PeakTracker, fs: Array, st: Array, t_max: float, max_steps: int, method: str) -> str:
    """The stop message PeakTracker gives for the kernel's code (same wording as the scipy engines)."""
    t = float(fs[K.T])
    if code == K.DIED:
        k = int(st[K.DIED_AT])
        why = primary_pulse_lost(track.peaks, k, track.first, track.death_fraction, track.overtake_factor,
                                 track.times)
        track.died_at = k
        return f"pulse died at contact {k} ({why})"
    if code == K.BLOWUP:
        track.check_state(t, float(fs[K.E_LAST]), float(fs[K.E0]), ENERGY_BLOWUP)
        return track.reason
    if code == K.FAILED:
        return (f"integrator failed at t={t:.6g}: Required step size is less than spacing between numbers. "
                f"(compiled {method})")
    track.steps = int(st[K.STEPS]) - 1
    return track.check_progress(t, t_max, max_steps)


@dataclass
class _Run:
    """One chain's kernel state and settings (resumable; compiled_kernel's array layouts)."""

    beads: int
    exponent: float
    velocity: float
    first: int
    last: int
    rule: object
    rtol: float
    atol: float
    t_max: float
    max_steps: int
    table: "MonomialTable | JitForce"
    cap: int
    cf: Array
    ci: Array
    st: Array
    fs: Array
    peaks: Array
    times: Array
    pulse_e: Array
    total_e: Array
    y: Array
    f: Array
    method: str = METHOD  # the kernel: RK45 (compiled_kernel.py), DOP853 (compiled_dop853.py) or Rodas4
    terms: Array | None = None  # the contact law's term and the masses: contact_force.kernel_terms' ct
    vpeaks: Array | None = None  # bead velocity peaks, beads 1..last + 1 (tracked with masses; empty otherwise)


def prepare(chain: "Chain", contacts: tuple[int, int], table: "MonomialTable | JitForce | None", how: "Plan",
            integrator: "Integrator", stop: StopRules) -> _Run:
    """The kernel's arrays at t = 0 for ``chain`` (dns.Chain, checked by dns.simulate): all beads at rest, bead 1
    with velocity v0 (Eq. 1), or with a launch (chain/launch.Launch; the velocity scale is then its) the exact
    solitary wave with contact launch.centre at its peak, the window holding every bead it moves and contacts up
    to the centre counted as peaked; its contact law's term and masses. ``table``: the on-site force as the
    kernels take it (force_table.force_data); ``how``: plan()'s Plan (the kernel and the window rule);
    ``integrator``: rtol and atol; ``stop``: the stop rules with t_max and max_steps given."""
    beads, exponent, launch, contact, masses = chain.beads, chain.exponent, chain.launch, chain.contact, chain.masses
    velocity = chain.velocity if launch is None else launch.velocity_scale(exponent)
    rule, method, rtol, atol = how.rule, how.method, integrator.rtol, integrator.atol
    first, last = int(contacts[0]), int(contacts[1])
    peak_fraction, death_fraction, overtake_factor = stop.peak_fraction, stop.death_fraction, stop.overtake_factor
    stall_factor, t_max, max_steps = stop.stall_factor, float(stop.t_max), int(stop.max_steps)
    table = MonomialTable.zero() if table is None else table
    full = rule is None
    behind = beads + 1 if full else int(rule.behind)
    hi = min(beads, 3) if launch is None else min(beads, launch.front(exponent) + 1)
    cap = min(beads, max(0 if full else behind, hi) + ROOM)  # grown on demand: memory O(window), not O(N)
    cf = np.zeros(K.N_CF)
    cf[K.EXP], cf[K.RTOL], cf[K.ATOL], cf[K.T_MAXC] = exponent, rtol, atol, t_max
    cf[K.SCALE_X], cf[K.SCALE_V] = velocity_scale(velocity, exponent), velocity
    cf[K.AHEAD_THR] = 0.0 if full else float(rule.threshold)
    cf[K.PEAK_FRAC], cf[K.DEATH_FRAC], cf[K.OVERTAKE] = peak_fraction, death_fraction, overtake_factor
    cf[K.STALL_FAC], cf[K.E_LIMIT], cf[K.DELAY_FAC] = stall_factor, ENERGY_BLOWUP, DELAY_FACTOR
    ci = np.zeros(K.N_CI, dtype=np.int64)
    ci[K.BEADS], ci[K.FIRST], ci[K.LASTC], ci[K.BEHIND] = beads, first, last, behind
    ci[K.MAX_STEPS], ci[K.COAST], ci[K.ENERGY_EVERY] = max_steps, int(full or rule.boundary == "coast"), ENERGY_EVERY
    ci[K.CAPACITY] = cap
    st = np.zeros(K.N_ST, dtype=np.int64)
    st[K.HI], st[K.NEXT] = hi, 1 if launch is None else int(launch.centre) + 1
    st[K.WIDEST] = st[K.HI]
    fs = np.zeros(K.N_FS)
    fs[K.THRESH] = first_threshold(velocity, exponent, peak_fraction)
    fs[K.STALL] = stall_factor / contact_rate(velocity, exponent)
    y, f = np.zeros(2 * cap), np.zeros(2 * cap)
    if launch is None:
        y[1] = velocity
        fs[K.E0] = 0.5 * velocity * velocity * (1.0 if masses is None else float(masses[0]))
    else:
        y[: 2 * hi] = launch.state(exponent, hi)
        fs[K.E0] = energy(y[0 : 2 * hi : 2], y[1 : 2 * hi : 2], exponent)
    return _Run(beads, exponent, velocity, first, last, rule, float(rtol), float(atol), t_max, max_steps, table,
                cap, cf, ci, st, fs, np.full(last, np.nan), np.full(last, np.nan),
                np.full(last - first + 1, np.nan), np.full(last - first + 1, np.nan), y, f, method,
                kernel_terms(contact, masses), _velocity_peaks(masses, last, velocity, st))


def _velocity_peaks(masses, last: int, velocity: float, st: Array) -> Array:
    """Where the kernel puts the bead velocity peaks: beads 1..last + 1 with masses (bead 1's is its impact
    velocity: it only slows down), nothing without (the bare chain's kernel then tracks none)."""
    if masses is None:
        return np.zeros(0)
    vpeaks = np.full(last + 1, np.nan)
    vpeaks[0] = velocity
    st[K.VBEAD] = 2
    return vpeaks


def jit_kernel(method: str):
    """The numba dispatcher of a kernel (its module, chain/methods.py's row, imported, so compiled or loaded, only
    when a run needs it)."""
    import importlib

    return importlib.import_module(f"pulsemap.solvers.chain.{methods.by_name(method).kernel}").run


def kernel_for(run: _Run, aot: bool = True) -> tuple:
    """The kernel that integrates ``run``, the seconds it took to build, compile or load it and, of those,
    to build the ahead-of-time module (its first use on this machine): that module (compiled_aot.py) when
    one serves, else numba's JIT kernel (``aot=False``: always numba's). Both are compiled from the same
    functions and give the same numbers."""
    args = kernel_args(run)
    if aot:
        kernel, seconds, built = compiled_aot.kernel(run.method, args)
        if kernel is not None:
            return kernel, seconds, built
    from pulsemap.solvers.chain.jit import ready

    kernel = jit_kernel(run.method)
    return kernel, ready(kernel, args), 0.0


def kernel_args(run: _Run) -> tuple:
    """The kernel's arguments for ``run`` (compiled_kernel.run's order)."""
    return (run.y, run.f, run.fs, run.st, run.cf, run.ci, run.peaks, run.times, run.pulse_e, run.total_e, run.vpeaks,
            *run.table.kernel_args, run.terms)


def drive(run: _Run, kernel, code: int | None = None, report=None) -> int:
    """Run ``kernel`` (kernel_for's) until a stop rule fires (``code``: its last answer, if it ran already),
    growing the window's buffer whenever it asks for room. With ``report`` (a dns_progress.DNSProgress)
    the kernel pauses every PAUSE_STEPS accepted steps so the reporter can print its line; a pause
    changes no number (the kernel's state is complete between calls)."""
    if report is not None and report.enabled:
        run.ci[K.PAUSE_EVERY] = PAUSE_STEPS
    while True:
        if code == K.PAUSED:
            report.update(float(run.fs[K.T]), int(run.st[K.NEXT]) - 1,
                          f"compiled {run.method}, {int(run.st[K.NFEV])} RHS evaluations")
        elif code is not None and code != K.NEED_ROOM:
            return code
        if code == K.NEED_ROOM:
            w = int(run.st[K.HI] - run.st[K.LO])
            run.cap = min(run.beads, 2 * run.cap)
            run.ci[K.CAPACITY] = run.cap
            y, f = np.zeros(2 * run.cap), np.zeros(2 * run.cap)
            y[: 2 * w], f[: 2 * w] = run.y[: 2 * w], run.f[: 2 * w]
            run.y, run.f = y, f
        with warnings.catch_warnings():  # numba calls C function pointers (JitForce) 'experimental'
            warnings.filterwarnings("ignore", "First-class function type feature is experimental")
            code = int(kernel(*kernel_args(run)))


def result(run: _Run, code: int, wall: float, engine_reason: str = "") -> DNSResult:
    """The DNSResult of a finished run, with PeakTracker's stop message for the kernel's code."""
    cf, st, fs = run.cf, run.st, run.fs
    track = PeakTracker(run.first, run.last, float(cf[K.PEAK_FRAC]), float(cf[K.DEATH_FRAC]),
                        float(cf[K.OVERTAKE]), float(cf[K.STALL_FAC]), run.peaks, run.times,
                        float(fs[K.THRESH]), float(fs[K.STALL]), next_contact=int(st[K.NEXT]),
                        last_peak_time=float(fs[K.LAST_PEAK_T]), method=run.method)
    reason = _reason(code, track, fs, st, run.t_max, run.max_steps, run.method)
    contacts_out, peaks_out, times_out, alive = track.outcome()
    return DNSResult(
        contacts=contacts_out, peaks=peaks_out, peak_times=times_out, alive=alive, stop_reason=reason,
        method=run.method, rtol=run.rtol, atol=run.atol, beads=int(run.beads), nfev=int(st[K.NFEV]),
        njev=int(st[K.NJEV]),
        wall_time_s=wall, energy_drift=float(fs[K.DRIFT]) if run.table.conservative else None,
        exponent=float(run.exponent), velocity=float(run.velocity), t_end=float(fs[K.T]),
        mode="full" if run.rule is None else "window/compiled", window_beads=int(st[K.WIDEST]),
        window_shifts=int(st[K.SHIFTS]), window_rule=run.rule, blew_up=code == K.BLOWUP, steps=int(st[K.STEPS]),
        energy_initial=float(fs[K.E0]), pulse_energy=run.pulse_e, total_energy=run.total_e,
        engine="compiled", engine_reason=f"{engine_reason or explicit_reason(run.method)}, {run.table.describe}",
        velocity_peaks=run.vpeaks.copy() if run.vpeaks.size else None,
    )


def simulate_compiled(chain: "Chain", contacts: tuple[int, int], table: "MonomialTable | JitForce | None", how: "Plan",
                      integrator: "Integrator", stop: StopRules, *, progress: bool = False,
                      failure_note=None) -> DNSResult:
    """Eq. 1 on the compiled engine (arguments validated by dns.simulate, which calls it; prepare's: the option
    objects handed down as they are). ``progress``: a line on stderr at most every 5 s (dns_progress.DNSProgress),
    as the scipy engines. ``failure_note(lo, y)``: what a failed step size adds to the stop reason, from the
    window's state."""
    from pulsemap.solvers.chain.dns_progress import DNSProgress

    engine_reason = how.reason
    run = prepare(chain, contacts, table, how, integrator, stop)
    kernel, compile_s, build_s = kernel_for(run)
    wall0 = _time.perf_counter()
    code = drive(run, kernel, report=DNSProgress("dns", run.last, enabled=progress) if progress else None)
    if code == K.NONFINITE:  # dns.simulate locates the bead from the failed step's start (lo, y, f, h)
        lo, w = int(run.st[K.LO]), int(run.st[K.HI] - run.st[K.LO])
        raise ForceNotFinite(None, math.nan, math.nan, math.nan, t=float(run.fs[K.T]),
                             state=(lo, run.y[: 2 * w].copy(), run.f[: 2 * w].copy(), float(run.fs[K.H])))
    res = replace(result(run, code, _time.perf_counter() - wall0, engine_reason), compile_s=compile_s,
                  build_s=build_s)
    if code == K.FAILED and failure_note is not None:
        w = int(run.st[K.HI] - run.st[K.LO])
        res = replace(res, stop_reason=res.stop_reason + failure_note(int(run.st[K.LO]), run.y[: 2 * w]))
    return res
