"""numba bookkeeping after an accepted step of the compiled DNS of paper Eq. 1, shared by every kernel.

    x_i'' = (x_{i-1} - x_i)_+^n - (x_i - x_{i+1})_+^n + F_i(x_i, x_i')             (paper Eq. 1)

The kernels (compiled_kernel.py: Dormand-Prince 5(4); compiled_dop853.py: DOP853; compiled_stiff.py:
Rodas4) differ only in how a step is taken and in their dense output; what follows a step is here:
the blow-up guard, the leading-edge peaks (root of delta' = v_k - v_{k+1} on the dense output,
PeakTracker.record semantics), the stop rules (PeakTracker.check_progress order) and the moving
window's shifts.

A run's first call starts every kernel alike (``start``: f at t = 0 and Hairer's HINIT first step).

Dense output (Hairer's CONTD5 / CONTD8 form), per component i at t_old + theta h:
    y(theta) = y0 + theta (rc0 + (1 - theta) (rc1 + theta (rc2 + (1 - theta) (rc3 + theta (rc4 + ...)))))
DOPRI5 fills rc0..rc3 from its stages (order 4); rc3 = 0 is the cubic Hermite interpolant of
(y0, f0, y1, f1) (order 3), which the Rosenbrock kernel uses (compiled_ops.dopri_dense, hermite_dense);
DOP853 fills rc0..rc6 (order 7, compiled_dop853.dense_output).

Array layouts (fs, st, cf, ci) and return codes: compiled_layout.py.
"""

# numba cache stamp: b6266238713c7034
from __future__ import annotations

import numpy as np
from pulsemap.solvers.chain.jit import njit

from pulsemap.solvers.chain.compiled_layout import (
    LAST_PEAKED, DIED, STALLED, T_MAX, BUDGET, BLOWUP, FAILED, NEED_ROOM, PAUSED, T, H, LEFT_X, LEFT_V, LEFT_T, E0,
    E_GONE, DRIFT, THRESH, LAST_PEAK_T, STALL, E_LAST, LO, HI, NEXT, STEPS, NFEV, HAS_LEFT, DIED_AT, WIDEST, SHIFTS,
    LOST, VBEAD, EXP, T_MAXC, SCALE_X, SCALE_V, AHEAD_THR, PEAK_FRAC, DEATH_FRAC, OVERTAKE, STALL_FAC, E_LIMIT, DELAY_FAC,
    BEADS, FIRST, LASTC, BEHIND, MAX_STEPS, COAST, CAPACITY, ENERGY_EVERY, PAUSE_EVERY, RTOL, ATOL, STARTED, FACOLD)
from pulsemap.solvers.chain.compiled_force import contact_force, inverse_mass
from pulsemap.solvers.chain.compiled_ops import NO_NRT, PULSE_HALF_WIDTH, pulse_lost, rhs, segment_energy, window_energy


@njit(**NO_NRT)
def dense_value(theta, i, y0, rc):
    """Component i of the dense output at t_old + theta h (module docstring; as many rows as rc has)."""
    th1 = 1.0 - theta
    v = rc[rc.shape[0] - 1, i]
    for r in range(rc.shape[0] - 2, -1, -1):
        v = rc[r, i] + (th1 if r % 2 == 0 else theta) * v
    return y0[i] + theta * v


@njit(**NO_NRT)
def dense_slope(theta, i, y0, rc):
    """d/dtheta of component i of the dense output (dense_value's nested form differentiated)."""
    th1 = 1.0 - theta
    v = rc[rc.shape[0] - 1, i]
    dv = 0.0
    for r in range(rc.shape[0] - 2, -1, -1):
        even = r % 2 == 0
        dv = (-v if even else v) + (th1 if even else theta) * dv
        v = rc[r, i] + (th1 if even else theta) * v
    return v + theta * dv


@njit(**NO_NRT)
def _root_side(kind, theta, i, j, y0, rc):
    """The function a root is sought of on the dense output: v_i - v_j (kind 0) or the slope of component i (kind 1)."""
    if kind == 0:
        return dense_value(theta, i, y0, rc) - dense_value(theta, j, y0, rc)
    return dense_slope(theta, i, y0, rc)


@njit(**NO_NRT)
def illinois(kind, i, j, y0, rc, fa, fb, h):
    """theta in (0, 1] of the root of _root_side(kind, ...) bracketed by fa > 0 at 0 and fb < 0 at 1 (Illinois
    method, to the spacing of floats in t = theta h)."""
    a, b = 0.0, 1.0
    side = 0
    c = 1.0
    for _ in range(200):
        c = (a * fb - b * fa) / (fb - fa)
        if not (a < c < b):
            c = 0.5 * (a + b)
        fc = _root_side(kind, c, i, j, y0, rc)
        if fc == 0.0:
            return c
        if fc > 0.0:
            a, fa = c, fc
            if side == -1:
                fb *= 0.5
            side = -1
        else:
            b, fb = c, fc
            if side == 1:
                fa *= 0.5
            side = 1
        if (b - a) * abs(h) < 1e-15 + 4.0 * 2.220446049250313e-16 * abs(h) * c:
            break
    return c


@njit(**NO_NRT)
def locate(p, q, y0, y1, rc, h):
    """theta of the root of delta' = v_p - v_q in (0, 1] on the dense output (Illinois method)."""
    fa = y0[2 * p + 1] - y0[2 * q + 1]
    fb = y1[2 * p + 1] - y1[2 * q + 1]
    if fb == 0.0:
        return 1.0
    return illinois(0, 2 * p + 1, 2 * q + 1, y0, rc, fa, fb, h)


@njit(cache=True, inline="always")
def window_now(st, fs, ci):
    """The window a step integrates: (lo, w, wall, has_left, w2, lx, lv, lt): its first bead (0-based),
    its beads, whether bead hi is a wall at rest, whether a dropped bead coasts on its left (at lx,
    lv since lt), and its 2w components."""
    w = st[HI] - st[LO]
    return (st[LO], w, st[HI] < ci[BEADS], st[HAS_LEFT] == 1, 2 * w, fs[LEFT_X], fs[LEFT_V], fs[LEFT_T])


@njit(cache=True, inline="always")
def next_step(t, h, st, fs, cf, ci):
    """The next step's size (h clipped to t_max) and a stop code: NEED_ROOM when no bead can be added
    ahead (the caller grows the buffer), FAILED when h underflows; t and h are saved for a resume."""
    if st[HI] - st[LO] >= ci[CAPACITY] and st[HI] < ci[BEADS]:
        fs[T], fs[H] = t, h
        return h, NEED_ROOM
    if h > cf[T_MAXC] - t:
        h = cf[T_MAXC] - t
    if abs(h) <= 10.0 * 2.220446049250313e-16 * abs(t) or not np.isfinite(h):
        fs[T], fs[H] = t, h
        return h, FAILED
    return h, 0


@njit(cache=True, inline="always")
def peak_in_step(y, yn, f, fn, st, ci, vpeaks):
    """True when the next contact's delta' turns from + to - over the step, or (bead velocity peaks tracked)
    the next bead's acceleration does (f, fn: the right-hand side at the step's ends): the dense output is needed."""
    k = st[NEXT]
    if k <= min(ci[LASTC], st[HI] - 1):
        p = k - 1 - st[LO]
        if y[2 * p + 1] - y[2 * p + 3] > 0.0 and yn[2 * p + 1] - yn[2 * p + 3] <= 0.0:
            return True
    if vpeaks.shape[0] > 0:
        b = st[VBEAD] - 1 - st[LO]
        if st[VBEAD] <= vpeaks.shape[0] and 0 <= b < st[HI] - st[LO]:
            return f[2 * b + 1] > 0.0 and fn[2 * b + 1] <= 0.0
    return False


@njit(**NO_NRT)
def locate_max(i, y0, rc, h):
    """theta in [0, 1] of the maximum of component i on the dense output (the root of its slope; an end when the
    slope does not change sign there)."""
    fa, fb = dense_slope(0.0, i, y0, rc), dense_slope(1.0, i, y0, rc)
    if fa <= 0.0:
        return 0.0
    if fb >= 0.0:
        return 1.0
    return illinois(1, i, 0, y0, rc, fa, fb, h)


@njit(**NO_NRT)
def track_velocity(y, yn, f, fn, rc, h, w, st, cf, vpeaks):
    """The bead velocity peaks completed in the step (the first maximum in time of v_b, above peak_fraction of
    the previous bead's): vpeaks[b - 1] for bead b = st[VBEAD], ...; a bead dropped before its peak keeps NaN."""
    lo = st[LO]
    while st[VBEAD] <= vpeaks.shape[0]:
        b = st[VBEAD] - 1 - lo
        if b < 0:
            st[VBEAD] += 1
            continue
        if b >= w or not (f[2 * b + 1] > 0.0 and fn[2 * b + 1] <= 0.0):
            return
        value = dense_value(locate_max(2 * b + 1, y, rc, h), 2 * b + 1, y, rc)
        bead = st[VBEAD]
        if bead > 1 and vpeaks[bead - 2] == vpeaks[bead - 2] and not value > cf[PEAK_FRAC] * vpeaks[bead - 2]:
            return  # a ripple ahead of the front: the bead's peak is still to come
        vpeaks[bead - 1] = value
        st[VBEAD] += 1


@njit(cache=True, inline="always")
def track_step(t_old, t, h, y, yn, rc, pk, w, st, fs, cf, ci, peaks, times, pulse_e, total_e, ct, f, fn, vpeaks):
    """After an accepted step t_old -> t (state y -> yn, dense output rc): the blow-up guard (energy
    every ci[ENERGY_EVERY] steps), the leading-edge peaks completed in the step, at each requested
    contact's peak the energies of front.FrontRecorder (``pulse_e``: beads k-8..k+8, ``total_e``:
    the window plus what dropped beads carried; ``pk``: scratch), then the stop rules.
    ``vpeaks``: the bead velocity peaks (track_velocity; empty: not tracked), f and fn the right-hand side at
    the step's ends. Returns the stop code (0: go on)."""
    if vpeaks.shape[0] > 0:
        track_velocity(y, yn, f, fn, rc, h, w, st, cf, vpeaks)
    n = cf[EXP]
    lo = st[LO]
    w2 = 2 * w
    first, last = ci[FIRST], ci[LASTC]
    has_left = st[HAS_LEFT] == 1
    code = 0
    if st[STEPS] % ci[ENERGY_EVERY] == 0 or not np.isfinite(yn[w2 - 1] + yn[0]):
        e_now = window_energy(t, yn, w, n, has_left, fs[LEFT_X], fs[LEFT_V], fs[LEFT_T], lo, ct) + fs[E_GONE]
        fs[E_LAST] = e_now
        if not np.isfinite(e_now) or not e_now <= cf[E_LIMIT] * fs[E0]:
            return BLOWUP
        fs[DRIFT] = max(fs[DRIFT], abs(e_now - fs[E0]) / fs[E0])
    k = st[NEXT]
    top = min(last, st[HI] - 1)
    t_floor = t_old
    while k <= top:
        p = k - 1 - lo
        q = k - lo
        if not (y[2 * p + 1] - y[2 * q + 1] > 0.0 and yn[2 * p + 1] - yn[2 * q + 1] <= 0.0):
            break
        theta = locate(p, q, y, yn, rc, h)
        t_pk = t_old + theta * h
        value = dense_value(theta, 2 * p, y, rc) - dense_value(theta, 2 * q, y, rc)
        if not value > fs[THRESH] or t_pk < t_floor:
            break
        peaks[k - 1] = value
        times[k - 1] = t_pk
        if k >= first:
            for i in range(w2):
                pk[i] = dense_value(theta, i, y, rc)
            kl = k - 1 - lo
            pulse_e[k - first] = segment_energy(pk, max(0, kl - PULSE_HALF_WIDTH), min(w, kl + PULSE_HALF_WIDTH + 1), n,
                                                   lo, ct)
            # w - w: not a literal 0 (one compile)
            total_e[k - first] = segment_energy(pk, w - w, w, n, lo, ct) + fs[E_GONE]
        fs[STALL] = cf[STALL_FAC] * (t_pk - fs[LAST_PEAK_T])
        fs[LAST_PEAK_T] = t_pk
        fs[THRESH] = cf[PEAK_FRAC] * value
        st[NEXT] = k + 1
        why = pulse_lost(peaks, times, k, first, cf[DEATH_FRAC], cf[OVERTAKE], cf[DELAY_FAC])
        if why != 0:
            st[DIED_AT] = k
            st[LOST] = why
            break
        t_floor = t_pk
        k += 1
    st[STEPS] += 1
    if st[DIED_AT] > 0:
        code = DIED
    elif st[NEXT] > last:
        code = LAST_PEAKED
    elif t - fs[LAST_PEAK_T] > fs[STALL]:
        code = STALLED
    elif t >= cf[T_MAXC]:
        code = T_MAX
    elif st[STEPS] >= ci[MAX_STEPS]:
        code = BUDGET
    return code


@njit(cache=True, inline="always")
def drop_behind(t, y, f, w, st, fs, cf, ci, ct):
    """Drop the beads more than ``behind`` behind the last peaked contact (the last one coasts, or the
    chain gets a free end); the energy they carry goes to fs[E_GONE]. Returns (w, the caller must
    re-evaluate f: the first bead lost its left contact)."""
    n = cf[EXP]
    lo = st[LO]
    drop = st[NEXT] - 1 - ci[BEHIND] - lo
    if drop <= 0:
        return w, False
    e_before = window_energy(t, y, w, n, st[HAS_LEFT] == 1, fs[LEFT_X], fs[LEFT_V], fs[LEFT_T], lo, ct)
    j = drop - 1  # local index of the last dropped bead
    if ci[COAST] == 1:
        fs[LEFT_X], fs[LEFT_V], fs[LEFT_T] = y[2 * j], y[2 * j + 1], t
        st[HAS_LEFT] = 1
    else:
        st[HAS_LEFT] = 0
    for i in range(2 * (w - drop)):
        y[i] = y[i + 2 * drop]
        f[i] = f[i + 2 * drop]  # coast: the new left contact pushes exactly as before
    st[LO] = lo + drop
    w -= drop
    fs[E_GONE] += e_before - window_energy(t, y, w, n, st[HAS_LEFT] == 1, fs[LEFT_X], fs[LEFT_V], fs[LEFT_T],
                                          st[LO], ct)
    st[SHIFTS] += 1
    return w, ci[COAST] == 0


@njit(cache=True, inline="always")
def add_ahead(y, f, w, st, cf, ci, ct):
    """A bead at rest ahead when the last one has moved by more than the threshold (relative to
    v0^(2/(n+1)) and v0): the wall it replaces pushed exactly as it does (F(0, 0) = 0 is checked by
    the caller). Returns w; records the widest window."""
    if st[HI] < ci[BEADS] and (abs(y[2 * w - 2]) / cf[SCALE_X] + abs(y[2 * w - 1]) / cf[SCALE_V]) > cf[AHEAD_THR]:
        y[2 * w] = 0.0
        y[2 * w + 1] = 0.0
        f[2 * w] = 0.0
        d = y[2 * w - 2]
        hi = st[HI]
        f[2 * w + 1] = contact_force(d, y[2 * w - 1], hi - 1, cf[EXP], ct) * inverse_mass(hi, ct) if d > 0.0 else 0.0
        st[HI] += 1
        w += 1
    if w > st[WIDEST]:
        st[WIDEST] = w
    return w


@njit(cache=True, inline="always")
def accept(t, h, y, f, yn, fn, w2, fs):
    """The step is taken: y <- yn, f <- fn (f at the new point), t and the next h saved."""
    for i in range(w2):
        y[i] = yn[i]
        f[i] = fn[i]
    fs[T], fs[H] = t, h


@njit(cache=True, inline="always")
def pause_now(st, ci) -> bool:
    """True after every ci[PAUSE_EVERY]-th accepted step (the state is complete: the caller resumes
    exactly where the kernel stopped, so a paused run gives the same numbers as one that is not)."""
    return ci[PAUSE_EVERY] > 0 and st[STEPS] % ci[PAUSE_EVERY] == 0


@njit(cache=True, inline="always")
def shift_window(t, y, f, w, st, fs, cf, ci, exps, coef, ct):
    """drop_behind (f re-evaluated when the chain got a free end), then add_ahead: the new w."""
    w, refresh = drop_behind(t, y, f, w, st, fs, cf, ci, ct)
    if refresh:  # free: the first bead lost its left contact
        # has_left as st[HAS_LEFT] == 1 (False here), not a literal False: rhs is compiled once
        rhs(t, y, f, w, st[LO], cf[EXP], st[HAS_LEFT] == 1, 0.0, 0.0, 0.0, st[HI] < ci[BEADS], exps, coef, ct)
        st[NFEV] += 1
    return add_ahead(y, f, w, st, cf, ci, ct)


@njit(cache=True, inline="always")
def finish_step(t, h_new, y, f, yn, fn, w, st, fs, cf, ci, exps, coef, ct, code):
    """After track_step: accept the step (y <- yn, f <- fn), then, unless ``code`` stops the run, shift
    the window and pause for a progress line when it is due. Returns the code (PAUSED, or 0: go on)."""
    accept(t, h_new, y, f, yn, fn, 2 * w, fs)
    if code != 0:
        return code
    shift_window(t, y, f, w, st, fs, cf, ci, exps, coef, ct)
    return PAUSED if pause_now(st, ci) else 0


@njit(**NO_NRT)
def _initial_step(t, y, f, w, st, fs, cf, exps, coef, ct, wall, work):
    """Hairer's HINIT for the first step."""
    w2 = 2 * w
    rtol, atol = cf[RTOL], cf[ATOL]
    sk = work[7]
    y1 = work[8]
    f1 = work[6]
    dnf = 0.0
    dny = 0.0
    for i in range(w2):
        s = atol + rtol * abs(y[i])
        sk[i] = s
        dnf += (f[i] / s) ** 2
        dny += (y[i] / s) ** 2
    dnf, dny = np.sqrt(dnf / w2), np.sqrt(dny / w2)
    h = 1e-6 if (dnf <= 1e-10 or dny <= 1e-10) else 0.01 * dny / dnf
    h = min(h, cf[T_MAXC] - t)
    for i in range(w2):
        y1[i] = y[i] + h * f[i]
    rhs(t + h, y1, f1, w, st[LO], cf[EXP], st[HAS_LEFT] == 1, fs[LEFT_X], fs[LEFT_V], fs[LEFT_T], wall, exps, coef, ct)
    st[NFEV] += 1
    der2 = 0.0
    for i in range(w2):
        der2 += ((f1[i] - f[i]) / sk[i]) ** 2
    der2 = np.sqrt(der2 / w2) / h
    der12 = max(abs(der2), np.sqrt(dnf))
    h1 = max(1e-6, h * 1e-3) if der12 <= 1e-15 else (0.01 / der12) ** 0.2
    return min(100.0 * h, h1, cf[T_MAXC] - t)


@njit(**NO_NRT)
def start(t, y, f, st, fs, cf, ci, exps, coef, ct, work):
    """At a run's first call (st[STARTED] == 0): f at t and the first step size (HINIT)."""
    if st[STARTED] == 0:
        w = st[HI] - st[LO]
        wall = st[HI] < ci[BEADS]
        rhs(t, y, f, w, st[LO], cf[EXP], st[HAS_LEFT] == 1, fs[LEFT_X], fs[LEFT_V], fs[LEFT_T], wall, exps, coef, ct)
        st[NFEV] += 1
        fs[H] = _initial_step(t, y, f, w, st, fs, cf, exps, coef, ct, wall, work)
        fs[FACOLD] = 1e-4
        st[STARTED] = 1
