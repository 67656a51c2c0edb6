"""numba kernel: moving-window Dormand-Prince 5(4) integration of paper Eq. 1 with peak tracking.

    x_i'' = (x_{i-1} - x_i)_+^n - (x_i - x_{i+1})_+^n + F_i(x_i, x_i'),
    F_i(x, v) = sum_m c_m[i] x^(a_m) v^(b_m), or a generated numba function     (paper Eq. 1)

The on-site force enters as data (a monomial table: exponents (a_m, b_m) and per-bead
coefficients c_m[i], eps and the perturbed range folded in), so one compiled kernel serves every
polynomial R; a non-polynomial R enters as C callables with per-bead arguments, so one more
specialisation serves every other R (solvers/chain/compiled_force.py). The whole run (steps,
PI step control, window shifts, leading-edge peaks on the dense output, stop rules) happens in
``run``; solvers/chain/compiled.py wraps it and builds DNSResult.

State layout: interleaved y = [x_lo, v_lo, x_lo+1, v_lo+1, ...] for the window beads lo..hi-1
(0-based), stored from index 0 of a buffer of ``capacity`` beads. Bead hi (if hi < N) is a wall
at rest (x = 0); bead lo-1, if dropped, coasts with the velocity it had when dropped.
"""

# numba cache stamp: b6266238713c7034
from __future__ import annotations

import numpy as np
from pulsemap.solvers.chain.jit import njit

from pulsemap.solvers.chain.compiled_force import lean
from pulsemap.solvers.chain.compiled_ops import (
    A21, A31, A32, A41, A42, A43, A51, A52, A53, A54, A61, A62, A63, A64, A65, A71, A73, A74, A75, A76, BETA, C2, C3,
    C4, C5, E1, E3, E4, E5, E6, E7, FAC_MAX, FAC_MIN, NO_NRT, SAFE, dopri_dense, rhs)
from pulsemap.solvers.chain.compiled_layout import ATOL, CAPACITY, EXP, FACOLD, H, NFEV, NONFINITE, REJECTED, RTOL, T
from pulsemap.solvers.chain.compiled_track import finish_step, next_step, peak_in_step, start, track_step, window_now


@njit(cache=True)
def run(y, f, fs, st, cf, ci, peaks, times, pulse_e, total_e, vpeaks, exps, coef, ct):
    """Integrate until a stop rule fires; returns its code (state in y, f, fs, st for a resume).
    Allocates the scratch arrays, then ``steps`` (compiled without reference counting) does the work."""
    cap = ci[CAPACITY]
    return steps(y, f, fs, st, cf, ci, peaks, times, pulse_e, total_e, vpeaks, *lean(exps, coef, ct),
                 np.empty((10, 2 * cap)), np.empty((4, 2 * cap)))


@njit(**NO_NRT)
def steps(y, f, fs, st, cf, ci, peaks, times, pulse_e, total_e, vpeaks, exps, coef, ct, work, rc):
    """The steps of ``run`` (``work``: 10 rows of scratch, ``rc``: the dense output's 4 rows, each of
    2 x ci[CAPACITY]).

    Per accepted step, in the order of solvers/window.simulate_windowed: blow-up guard (energy
    every ci[ENERGY_EVERY] steps), leading-edge peaks (PeakTracker.record semantics), stop rules
    (PeakTracker.check_progress order), then the window: beads more than ``behind`` behind the
    last peaked contact are dropped (the last one coasts), and a bead at rest is added ahead when
    the last bead has moved by more than the threshold (relative to v0^(2/(n+1)) and v0).
    At each requested contact's peak, the energies of front.FrontRecorder: of beads k-8..k+8
    (``pulse_e``) and of the window plus what dropped beads carried (``total_e``).
    """
    n = cf[EXP]
    rtol, atol = cf[RTOL], cf[ATOL]
    k2, k3, k4, k5, k6, k7, ys, yn = work[0], work[1], work[2], work[3], work[4], work[5], work[8], work[9]
    expo1 = 0.2 - BETA * 0.75
    t = fs[T]
    start(t, y, f, st, fs, cf, ci, exps, coef, ct, work)
    h = fs[H]
    while True:
        h, code = next_step(t, h, st, fs, cf, ci)
        if code != 0:
            return code
        lo, w, wall, has_left, w2, lx, lv, lt = window_now(st, fs, ci)
        # ---- stages
        for i in range(w2):
            ys[i] = y[i] + h * A21 * f[i]
        rhs(t + C2 * h, ys, k2, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)
        for i in range(w2):
            ys[i] = y[i] + h * (A31 * f[i] + A32 * k2[i])
        rhs(t + C3 * h, ys, k3, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)
        for i in range(w2):
            ys[i] = y[i] + h * (A41 * f[i] + A42 * k2[i] + A43 * k3[i])
        rhs(t + C4 * h, ys, k4, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)
        for i in range(w2):
            ys[i] = y[i] + h * (A51 * f[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i])
        rhs(t + C5 * h, ys, k5, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)
        for i in range(w2):
            ys[i] = y[i] + h * (A61 * f[i] + A62 * k2[i] + A63 * k3[i] + A64 * k4[i] + A65 * k5[i])
        rhs(t + h, ys, k6, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)
        for i in range(w2):
            yn[i] = y[i] + h * (A71 * f[i] + A73 * k3[i] + A74 * k4[i] + A75 * k5[i] + A76 * k6[i])
        rhs(t + h, yn, k7, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)
        st[NFEV] += 6
        err = 0.0
        for i in range(w2):
            sk = atol + rtol * max(abs(y[i]), abs(yn[i]))
            e = h * (E1 * f[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i] + E7 * k7[i]) / sk
            err += e * e
        err = np.sqrt(err / w2)
        fac11 = err**expo1 if err > 0.0 else 0.0
        if err != err:  # NaN: a stage met a non-finite force; t and h kept for compiled.py to locate it
            fs[T], fs[H] = t, h
            return NONFINITE
        if not err <= 1.0:  # rejected
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
        if peak_in_step(y, yn, f, k7, st, ci, vpeaks):
            dopri_dense(rc, y, yn, h, f, k3, k4, k5, k6, k7, w2)
        code = track_step(t_old, t, h, y, yn, rc, work[6], w, st, fs, cf, ci, peaks, times, pulse_e, total_e, ct,
                          f, k7, vpeaks)
        code = finish_step(t, h_new, y, f, yn, k7, w, st, fs, cf, ci, exps, coef, ct, code)  # FSAL: f <- k7
        h = h_new
        if code != 0:
            return code
