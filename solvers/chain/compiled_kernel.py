"""numba kernel: moving-window Dormand-Prince 5(4) integration of paper Eq. 1 with peak tracking.

    x_i'' = (x_{i-1} - x_i)_+^n - (x_i - x_{i+1})_+^n + F_i(x_i, x_i'),
    F_i(x, v) = sum_m c_m[i] x^(a_m) v^(b_m)                               (paper Eq. 1)

The on-site force enters as data (a monomial table: exponents (a_m, b_m) and per-bead
coefficients c_m[i], eps and the perturbed range folded in), so one compiled kernel serves every
polynomial R. The whole run (steps, PI step control, window shifts, leading-edge peaks on the
dense output, stop rules) happens in ``run``; solvers/chain/compiled.py wraps it and builds DNSResult.

State layout: interleaved y = [x_lo, v_lo, x_lo+1, v_lo+1, ...] for the window beads lo..hi-1
(0-based), stored from index 0 of a buffer of ``capacity`` beads. Bead hi (if hi < N) is a wall
at rest (x = 0); bead lo-1, if dropped, coasts with the velocity it had when dropped.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from pulsemap.solvers.chain.compiled_ops import (
    A21, A31, A32, A41, A42, A43, A51, A52, A53, A54, A61, A62, A63, A64, A65, A71, A73, A74, A75, A76, BETA, C2, C3,
    C4, C5, E1, E3, E4, E5, E6, E7, FAC_MAX, FAC_MIN, PULSE_HALF_WIDTH, SAFE, _dense, _locate, _pow, pulse_lost, rhs,
    segment_energy, window_energy)

# --- return codes of run (solvers/chain/compiled.py turns them into PeakTracker's messages)
LAST_PEAKED, DIED, STALLED, T_MAX, BUDGET, BLOWUP, FAILED, NEED_ROOM = 1, 2, 3, 4, 5, 6, 7, 8

# --- float state fs[...] (resumable between calls)
T, H, FACOLD, LEFT_X, LEFT_V, LEFT_T, E0, E_GONE, DRIFT, THRESH, LAST_PEAK_T, STALL, E_LAST = range(13)
N_FS = 13
# --- int state st[...]
LO, HI, NEXT, STEPS, NFEV, HAS_LEFT, REJECTED, DIED_AT, WIDEST, SHIFTS, STARTED, LOST = range(12)
N_ST = 12
# --- float config cf[...]
EXP, RTOL, ATOL, T_MAXC, SCALE_X, SCALE_V, AHEAD_THR, PEAK_FRAC, DEATH_FRAC, OVERTAKE, STALL_FAC, E_LIMIT, \
    DELAY_FAC = range(13)
N_CF = 13
# --- int config ci[...]
BEADS, FIRST, LASTC, BEHIND, MAX_STEPS, COAST, CAPACITY, ENERGY_EVERY = range(8)
N_CI = 8


@njit(cache=True)
def _initial_step(t, y, f, w, st, fs, cf, exps, coef, wall, work):
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
    rhs(t + h, y1, f1, w, st[LO], cf[EXP], st[HAS_LEFT] == 1, fs[LEFT_X], fs[LEFT_V], fs[LEFT_T], wall, exps, coef)
    st[NFEV] += 1
    der2 = 0.0
    for i in range(w2):
        der2 += ((f1[i] - f[i]) / sk[i]) ** 2
    der2 = np.sqrt(der2 / w2) / h
    der12 = max(abs(der2), np.sqrt(dnf))
    h1 = max(1e-6, h * 1e-3) if der12 <= 1e-15 else (0.01 / der12) ** 0.2
    return min(100.0 * h, h1, cf[T_MAXC] - t)


@njit(cache=True)
def run(y, f, fs, st, cf, ci, peaks, times, pulse_e, total_e, exps, coef):
    """Integrate until a stop rule fires; returns its code (state in y, f, fs, st for a resume).

    Per accepted step, in the order of solvers/window.simulate_windowed: blow-up guard (energy
    every ci[ENERGY_EVERY] steps), leading-edge peaks (PeakTracker.record semantics), stop rules
    (PeakTracker.check_progress order), then the window: beads more than ``behind`` behind the
    last peaked contact are dropped (the last one coasts), and a bead at rest is added ahead when
    the last bead has moved by more than the threshold (relative to v0^(2/(n+1)) and v0).
    At each requested contact's peak, the energies of front.FrontRecorder: of beads k-8..k+8
    (``pulse_e``) and of the window plus what dropped beads carried (``total_e``).
    """
    n = cf[EXP]
    rtol, atol, t_max = cf[RTOL], cf[ATOL], cf[T_MAXC]
    beads, first, last, behind = ci[BEADS], ci[FIRST], ci[LASTC], ci[BEHIND]
    cap = ci[CAPACITY]
    work = np.empty((10, 2 * cap))
    k2, k3, k4, k5, k6, k7, ys, yn = work[0], work[1], work[2], work[3], work[4], work[5], work[8], work[9]
    expo1 = 0.2 - BETA * 0.75
    uround = 2.220446049250313e-16
    t = fs[T]
    w = st[HI] - st[LO]
    wall = st[HI] < beads
    if st[STARTED] == 0:
        rhs(t, y, f, w, st[LO], n, st[HAS_LEFT] == 1, fs[LEFT_X], fs[LEFT_V], fs[LEFT_T], wall, exps, coef)
        st[NFEV] += 1
        fs[H] = _initial_step(t, y, f, w, st, fs, cf, exps, coef, wall, work)
        fs[FACOLD] = 1e-4
        st[STARTED] = 1
    h = fs[H]
    while True:
        lo = st[LO]
        w = st[HI] - lo
        w2 = 2 * w
        wall = st[HI] < beads
        has_left = st[HAS_LEFT] == 1
        lx, lv, lt = fs[LEFT_X], fs[LEFT_V], fs[LEFT_T]
        if w >= cap and st[HI] < beads:  # no room for a bead ahead: the caller grows the buffer
            fs[T], fs[H] = t, h
            return NEED_ROOM
        if h > t_max - t:
            h = t_max - t
        if abs(h) <= 10.0 * uround * abs(t) or not np.isfinite(h):
            fs[T], fs[H] = t, h
            return FAILED
        # ---- stages
        for i in range(w2):
            ys[i] = y[i] + h * A21 * f[i]
        rhs(t + C2 * h, ys, k2, w, lo, n, has_left, lx, lv, lt, wall, exps, coef)
        for i in range(w2):
            ys[i] = y[i] + h * (A31 * f[i] + A32 * k2[i])
        rhs(t + C3 * h, ys, k3, w, lo, n, has_left, lx, lv, lt, wall, exps, coef)
        for i in range(w2):
            ys[i] = y[i] + h * (A41 * f[i] + A42 * k2[i] + A43 * k3[i])
        rhs(t + C4 * h, ys, k4, w, lo, n, has_left, lx, lv, lt, wall, exps, coef)
        for i in range(w2):
            ys[i] = y[i] + h * (A51 * f[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i])
        rhs(t + C5 * h, ys, k5, w, lo, n, has_left, lx, lv, lt, wall, exps, coef)
        for i in range(w2):
            ys[i] = y[i] + h * (A61 * f[i] + A62 * k2[i] + A63 * k3[i] + A64 * k4[i] + A65 * k5[i])
        rhs(t + h, ys, k6, w, lo, n, has_left, lx, lv, lt, wall, exps, coef)
        for i in range(w2):
            yn[i] = y[i] + h * (A71 * f[i] + A73 * k3[i] + A74 * k4[i] + A75 * k5[i] + A76 * k6[i])
        rhs(t + h, yn, k7, w, lo, n, has_left, lx, lv, lt, wall, exps, coef)
        st[NFEV] += 6
        err = 0.0
        for i in range(w2):
            sk = atol + rtol * max(abs(y[i]), abs(yn[i]))
            e = h * (E1 * f[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i] + E7 * k7[i]) / sk
            err += e * e
        err = np.sqrt(err / w2)
        fac11 = err**expo1 if err > 0.0 else 0.0
        if not err <= 1.0:  # rejected (NaN included: the step shrinks until it fails, as scipy's RK45)
            h = h / min(1.0 / FAC_MIN, fac11 / SAFE)
            st[REJECTED] = 1
            continue
        fac = fac11 / fs[FACOLD] ** BETA
        fac = max(1.0 / FAC_MAX, min(1.0 / FAC_MIN, fac / SAFE))
        h_new = h / fac
        fs[FACOLD] = max(err, 1e-4)
        if st[REJECTED] == 1:
            h_new = min(h_new, h)
        st[REJECTED] = 0
        t_old = t
        t = t + h
        # y_old stays in y until the bookkeeping is done (dense output needs y, f = k1, k3..k7)
        # ---- blow-up guard (before the peaks, as in the scipy engines)
        code = 0
        if st[STEPS] % ci[ENERGY_EVERY] == 0 or not np.isfinite(yn[w2 - 1] + yn[0]):
            e_now = window_energy(t, yn, w, n, has_left, lx, lv, lt) + fs[E_GONE]
            fs[E_LAST] = e_now
            if not np.isfinite(e_now) or not e_now <= cf[E_LIMIT] * fs[E0]:
                code = BLOWUP
            else:
                fs[DRIFT] = max(fs[DRIFT], abs(e_now - fs[E0]) / fs[E0])
        if code == 0:
            # ---- leading-edge peaks completed in this step (solvers.peaks.scan_step)
            k = st[NEXT]
            top = min(last, st[HI] - 1)
            t_floor = t_old
            while k <= top:
                p = k - 1 - lo
                q = k - lo
                if not (y[2 * p + 1] - y[2 * q + 1] > 0.0 and yn[2 * p + 1] - yn[2 * q + 1] <= 0.0):
                    break
                theta = _locate(p, q, y, yn, h, f, k3, k4, k5, k6, k7)
                t_pk = t_old + theta * h
                value = (_dense(theta, 2 * p, y, yn, h, f, k3, k4, k5, k6, k7)
                         - _dense(theta, 2 * q, y, yn, h, f, k3, k4, k5, k6, k7))
                if not value > fs[THRESH] or t_pk < t_floor:
                    break
                peaks[k - 1] = value
                times[k - 1] = t_pk
                if k >= first:
                    ys_pk = work[6]
                    for i in range(w2):
                        ys_pk[i] = _dense(theta, i, y, yn, h, f, k3, k4, k5, k6, k7)
                    kl = k - 1 - lo
                    pulse_e[k - first] = segment_energy(ys_pk, max(0, kl - PULSE_HALF_WIDTH),
                                                        min(w, kl + PULSE_HALF_WIDTH + 1), n)
                    total_e[k - first] = segment_energy(ys_pk, 0, w, n) + fs[E_GONE]
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
            # ---- stop rules (PeakTracker.check_progress order)
            st[STEPS] += 1
            if st[DIED_AT] > 0:
                code = DIED
            elif st[NEXT] > last:
                code = LAST_PEAKED
            elif t - fs[LAST_PEAK_T] > fs[STALL]:
                code = STALLED
            elif t >= t_max:
                code = T_MAX
            elif st[STEPS] >= ci[MAX_STEPS]:
                code = BUDGET
        # ---- accept: y <- y_new, f <- k7 (FSAL)
        for i in range(w2):
            y[i] = yn[i]
            f[i] = k7[i]
        h = h_new
        fs[T], fs[H] = t, h
        if code != 0:
            return code
        # ---- window: drop beads far behind the front
        drop = st[NEXT] - 1 - behind - lo
        if drop > 0:
            e_before = window_energy(t, y, w, n, has_left, lx, lv, lt)
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
            fs[E_GONE] += e_before - window_energy(t, y, w, n, st[HAS_LEFT] == 1, fs[LEFT_X], fs[LEFT_V],
                                                   fs[LEFT_T])
            st[SHIFTS] += 1
            if ci[COAST] == 0:  # free: the first bead lost its left contact
                rhs(t, y, f, w, st[LO], n, False, 0.0, 0.0, 0.0, st[HI] < beads, exps, coef)
                st[NFEV] += 1
        # ---- window: a bead at rest ahead when the last one has moved (the wall it replaces
        # pushed exactly as it does; F(0, 0) = 0 is checked by the caller)
        if st[HI] < beads and (abs(y[2 * w - 2]) / cf[SCALE_X] + abs(y[2 * w - 1]) / cf[SCALE_V]) > cf[AHEAD_THR]:
            y[2 * w] = 0.0
            y[2 * w + 1] = 0.0
            f[2 * w] = 0.0
            d = y[2 * w - 2]
            f[2 * w + 1] = _pow(d, n) if d > 0.0 else 0.0
            st[HI] += 1
            w += 1
        if w > st[WIDEST]:
            st[WIDEST] = w
