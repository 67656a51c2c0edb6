"""Compiled (numba) moving-window DNS of paper Eq. 1: the engine behind ``simulate(engine="compiled")``.

    x_i'' = (x_{i-1} - x_i)_+^n - (x_i - x_{i+1})_+^n + F_i(x_i, x_i')       (paper Eq. 1)

Dormand-Prince 5(4) with PI step control and dense output (solvers/chain/compiled_kernel.py), the same
leading-edge peaks (root of delta' on the dense output) and the same stop rules and messages as
the scipy engines (solvers/peaks.PeakTracker), and the same DNSResult.

Window (``rule``, a solvers.window.WindowRule): exactly ``rule.behind`` beads are kept behind
the last peaked contact (the last dropped bead coasts, ``rule.boundary``), the calibrated
accuracy rule of window.rule_for_accuracy; ahead, the window ends at the first bead at rest to
``rule.threshold`` (relative to v0^(2/(n+1)) and v0), followed by a wall at rest: a bead is added
as soon as the last one moves. ``rule=None`` is the full chain: nothing is dropped and the
window grows ahead as soon as the last bead moves at all (beads exactly at rest feel no force,
so this is the full chain's dynamics). The error norm is the RMS over the integrated beads.
F enters as a monomial table (the generated force module's MONOMIALS and monomial_coefficients,
derive/monomials.py), so a new polynomial R costs no compilation.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass

import numpy as np

from pulsemap.solvers.chain.equations import ENERGY_BLOWUP, DNSResult
from pulsemap.solvers.chain.peaks import PeakTracker, first_threshold, primary_pulse_lost, contact_rate, velocity_scale

Array = np.ndarray
METHOD = "RK45"  # Dormand-Prince 5(4), scipy's name for it
ENERGY_EVERY = 4  # blow-up guard and energy drift every this many steps (as solvers/window.py)
DELAY_FACTOR = 2.0  # peaks.primary_pulse_lost's default
ROOM = 96  # initial buffer beyond ``behind`` (grown on demand)


@dataclass(frozen=True)
class MonomialTable:
    """eps_i R_i(u, v) = sum_m coefficients[m, min(i-1, L-1)] u^a_m v^b_m (i 1-based bead), Eq. 1.

    ``exponents``: (M, 2) int64 (a_m, b_m); ``coefficients``: (M, L) float64, eps and the
    perturbed range folded in (``table_from_module`` builds both from the generated force module).
    """

    exponents: Array
    coefficients: Array

    @classmethod
    def of(cls, exponents, coefficients) -> "MonomialTable":
        e = np.ascontiguousarray(np.asarray(exponents, dtype=np.int64).reshape(-1, 2))
        c = np.ascontiguousarray(np.asarray(coefficients, dtype=np.float64))
        if c.ndim == 1:
            c = c.reshape(len(e), -1)
        if c.shape[0] != e.shape[0] or c.shape[1] < 1 or np.any(e < 0):
            raise ValueError(f"monomial table: exponents {e.shape} >= 0 and coefficients (M, L >= 1), got {c.shape}")
        if not np.all(np.isfinite(c)):
            raise ValueError("monomial table: coefficients must be finite")
        return cls(e, c)

    @classmethod
    def zero(cls) -> "MonomialTable":
        return cls(np.zeros((0, 2), dtype=np.int64), np.zeros((0, 1)))

    @property
    def constant_term(self) -> bool:
        """True when some bead has a nonzero u^0 v^0 term (R(0, 0) != 0: not a chain at rest)."""
        rows = np.flatnonzero((self.exponents[:, 0] == 0) & (self.exponents[:, 1] == 0))
        return bool(rows.size and np.any(self.coefficients[rows] != 0.0))


def table_from_module(module, index: Array, eps: Array, params: tuple) -> MonomialTable | None:
    """The generated force module's eps_i R_i as a table (None: R is not polynomial, or the module
    predates tables); columns past the last bead-dependent one are dropped (uniform R: O(1) memory)."""
    exponents = getattr(module, "MONOMIALS", None)
    if exponents is None:
        return None
    if not exponents:
        return MonomialTable.zero()
    with np.errstate(all="ignore"):
        coef = np.array([np.broadcast_to(np.asarray(c, float), index.shape)
                         for c in module.monomial_coefficients(index, eps, *params)])
    differs = np.flatnonzero(np.any(coef != coef[:, -1:], axis=0))
    columns = 1 if differs.size == 0 else int(differs[-1]) + 2
    return MonomialTable.of(exponents, coef[:, :columns].copy())


def unavailable(force, method: str, chosen: str, snapshots: bool = False) -> str:
    """Why the compiled engine cannot run this case ("" when it can): the scipy engine then runs."""
    if snapshots:
        return "strain snapshots are recorded by the scipy engine only"
    if method not in ("auto", METHOD):
        return f"method {method} has no compiled kernel (compiled: RK45, Dormand-Prince 5(4))"
    if chosen not in ("RK45", "DOP853"):
        return (f"stiff: the force's stiffness hint {force.stiffness_hint:g} exceeds 30 x the contact rate, "
                f"implicit {chosen} on the scipy engine")
    if force is None:
        return ""
    table = getattr(force, "monomials", None)
    if table is None:
        return "the on-site force has no monomial table (non-polynomial R or a Python callable)"
    if table.constant_term:
        return "R(0, 0) != 0: the monomial table has a constant term"
    return ""


def _reason(code: int, track: PeakTracker, fs: Array, st: Array, t_max: float, max_steps: int) -> str:
    """The stop message PeakTracker gives for the kernel's code (same wording as the scipy engines)."""
    from pulsemap.solvers.chain import compiled_kernel as K
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
                "(compiled RK45)")
    track.steps = int(st[K.STEPS]) - 1
    return track.check_progress(t, t_max, max_steps)


def simulate_compiled(
    beads: int,
    exponent: float,
    velocity: float,
    contacts: tuple[int, int],
    table: MonomialTable | None,
    *,
    rule=None,
    rtol: float,
    atol: float,
    peak_fraction: float,
    death_fraction: float,
    t_max: float,
    stall_factor: float,
    overtake_factor: float,
    max_steps: int,
    engine_reason: str = "",
) -> DNSResult:
    """Eq. 1 on the compiled engine (arguments validated by dns.simulate, which calls it)."""
    from pulsemap.solvers.chain import compiled_kernel as K  # numba: only when the engine runs
    first, last = int(contacts[0]), int(contacts[1])
    table = MonomialTable.zero() if table is None else table
    full = rule is None
    behind = beads + 1 if full else int(rule.behind)
    cap = min(beads, (0 if full else behind) + ROOM)  # grown on demand: memory O(window), not O(N)
    cf = np.zeros(K.N_CF)
    cf[K.EXP], cf[K.RTOL], cf[K.ATOL], cf[K.T_MAXC] = exponent, rtol, atol, t_max
    cf[K.SCALE_X], cf[K.SCALE_V] = velocity_scale(velocity, exponent), velocity
    cf[K.AHEAD_THR] = 0.0 if full else float(rule.threshold)
    cf[K.PEAK_FRAC], cf[K.DEATH_FRAC], cf[K.OVERTAKE] = peak_fraction, death_fraction, overtake_factor
    cf[K.STALL_FAC], cf[K.E_LIMIT], cf[K.DELAY_FAC] = stall_factor, ENERGY_BLOWUP, DELAY_FACTOR
    ci = np.zeros(K.N_CI, dtype=np.int64)
    ci[K.BEADS], ci[K.FIRST], ci[K.LASTC], ci[K.BEHIND] = beads, first, last, behind
    ci[K.MAX_STEPS], ci[K.COAST], ci[K.ENERGY_EVERY] = max_steps, int(full or rule.boundary == "coast"), ENERGY_EVERY
    st = np.zeros(K.N_ST, dtype=np.int64)
    st[K.HI], st[K.NEXT] = min(beads, 3), 1
    st[K.WIDEST] = st[K.HI]
    fs = np.zeros(K.N_FS)
    fs[K.E0] = 0.5 * velocity * velocity
    fs[K.THRESH] = first_threshold(velocity, exponent, peak_fraction)
    fs[K.STALL] = stall_factor / contact_rate(velocity, exponent)
    peaks, times = np.full(last, np.nan), np.full(last, np.nan)
    pulse_e, total_e = np.full(last - first + 1, np.nan), np.full(last - first + 1, np.nan)
    wall0 = _time.perf_counter()
    while True:
        ci[K.CAPACITY] = cap
        y, f = np.zeros(2 * cap), np.zeros(2 * cap)
        if st[K.STARTED] == 0:
            y[1] = velocity
        else:
            y[: len(y_keep)], f[: len(f_keep)] = y_keep, f_keep
        code = K.run(y, f, fs, st, cf, ci, peaks, times, pulse_e, total_e, table.exponents, table.coefficients)
        if code != K.NEED_ROOM:
            break
        w = int(st[K.HI] - st[K.LO])
        y_keep, f_keep = y[: 2 * w].copy(), f[: 2 * w].copy()
        cap = min(beads, 2 * cap)
    wall = _time.perf_counter() - wall0
    track = PeakTracker(first, last, peak_fraction, death_fraction, overtake_factor, stall_factor, peaks, times,
                        float(fs[K.THRESH]), float(fs[K.STALL]), next_contact=int(st[K.NEXT]),
                        last_peak_time=float(fs[K.LAST_PEAK_T]))
    reason = _reason(int(code), track, fs, st, t_max, max_steps)
    contacts_out, peaks_out, times_out, alive = track.outcome()
    return DNSResult(
        contacts=contacts_out, peaks=peaks_out, peak_times=times_out, alive=alive, stop_reason=reason,
        method=METHOD, rtol=float(rtol), atol=float(atol), beads=int(beads), nfev=int(st[K.NFEV]), njev=0,
        wall_time_s=wall, energy_drift=float(fs[K.DRIFT]) if table.exponents.shape[0] == 0 else None,
        exponent=float(exponent), velocity=float(velocity), t_end=float(fs[K.T]),
        mode="full" if full else "window/compiled", window_beads=int(st[K.WIDEST]),
        window_shifts=int(st[K.SHIFTS]), window_rule=rule, blew_up=code == K.BLOWUP, steps=int(st[K.STEPS]),
        energy_initial=float(fs[K.E0]), pulse_energy=pulse_e, total_energy=total_e,
        engine="compiled", engine_reason=engine_reason or "compiled RK45 (Dormand-Prince 5(4)), monomial table",
    )
