"""numba kernel for stiff on-site forces: moving-window Rodas4 (Rosenbrock) integration of paper Eq. 1.

    x_i'' = (x_{i-1} - x_i)_+^n - (x_i - x_{i+1})_+^n + F_i(x_i, x_i'),
    F_i(x, v) = sum_m c_m[i] x^(a_m) v^(b_m), or a generated numba function     (paper Eq. 1)

Rodas4 (Hairer & Wanner, Solving ODEs II, 1996: their RODAS coefficients; 6 stages, 5 new
right-hand sides, order 4, embedded order 3, stiffly accurate and L-stable), in Rosenbrock form:

    (1/(h gamma) - J) K_i = f(t + alpha_i h, y + sum_j a_ij K_j) + sum_j c_ij K_j / h + gamma_i h df/dt,
    y1 = y + sum_i m_i K_i,  error estimate K_6.

J is the exact Jacobian of Eq. 1 at the step's start: tridiagonal in the beads with 2x2 blocks
(contact stiffness n delta^(n-1) couples neighbours; dF/dx, dF/dv of the force, compiled_force.py,
sit on the diagonal), so eliminating K_x leaves a tridiagonal system in K_v: one factorisation and six
O(window) solves per step. df/dt is the coasting left bead's push. Dense output: the cubic
Hermite interpolant of (y, f) at the step's ends (order 3, compiled_ops.hermite_dense; f at the
new point is the next step's first stage). Window, peaks, stop rules: compiled_track.py, as the
explicit kernel (compiled_kernel.py), with the same state layout.
"""

# numba cache stamp: b6266238713c7034
from __future__ import annotations

import numpy as np
from pulsemap.solvers.chain.jit import njit

from pulsemap.solvers.chain.compiled_force import contact_slopes, has_terms, inverse_mass, lean, onsite_slopes
from pulsemap.solvers.chain.compiled_ops import NO_NRT, hermite_dense, rhs
from pulsemap.solvers.chain.compiled_layout import ATOL, CAPACITY, EXP, H, NFEV, NJEV, NONFINITE, REJECTED, RTOL, T
from pulsemap.solvers.chain.compiled_track import start, finish_step, next_step, peak_in_step, track_step, window_now

METHOD = "Rodas4"  # plan.STIFF_METHOD
ORDER = 4  # of the step (the embedded one: 3); the dense output is a cubic Hermite (order 3)
# --- the tableau (module docstring); a and c strictly lower triangular, row i = stage i + 1
GAMMA = 0.25
ALPHA = np.array([0.0, 0.386, 0.21, 0.63, 1.0, 1.0])
GAMMAS = np.array([0.25, -0.1043, 0.1035, -0.0362, 0.0, 0.0])  # gamma_i = sum_j gamma_ij
_A5 = [1.221224509226641, 6.019134481288629, 12.53708332932087, -0.6878860361058950]
A = np.array([[0.0] * 6,
              [1.544, 0.0, 0.0, 0.0, 0.0, 0.0],
              [0.9466785280815826, 0.2557011698983284, 0.0, 0.0, 0.0, 0.0],
              [3.314825187068521, 2.896124015972201, 0.9986419139977817, 0.0, 0.0, 0.0],
              _A5 + [0.0, 0.0],
              _A5 + [1.0, 0.0]])
C = np.array([[0.0] * 6,
              [-5.6688, 0.0, 0.0, 0.0, 0.0, 0.0],
              [-2.430093356833875, -0.2063599157091915, 0.0, 0.0, 0.0, 0.0],
              [-0.1073529058151375, -9.594562251023355, -20.47028614809616, 0.0, 0.0, 0.0],
              [7.496443313967647, -10.24680431464352, -33.99990352819905, 11.70890893206160, 0.0, 0.0],
              [8.083246795921522, -7.981132988064893, -31.52159432874371, 16.31930543123136, -6.058818238834054, 0.0]])
M = np.array(_A5 + [1.0, 1.0])  # y1 = y + sum_i m_i K_i (= stage 6's state + K_6: stiffly accurate)
STAGES = 6
SAFE, FAC_MIN, FAC_MAX = 0.9, 0.2, 6.0


@njit(**NO_NRT)
def jacobian(t, y, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct, band):
    """Eq. 1's Jacobian on the window: band[0, j] the stiffness dF/dd of the contact left of local bead j
    (j = 0: the coasting bead; band[0, w]: the wall), band[5, j] its damping dF/dw, band[1], band[2]
    dF/dx, dF/dv of the on-site force, band[6] the inverse masses. Returns df/dt of v_0 (the coasting
    bead's push)."""
    s, g = band[0], band[5]
    s[0] = 0.0
    g[0] = 0.0
    ft = 0.0
    if has_left:
        d = lx + lv * (t - lt) - y[0]
        if d > 0.0:
            s[0], g[0] = contact_slopes(d, lv - y[1], lo - 1, n, ct)
            ft = s[0] * lv * inverse_mass(lo, ct)
    for j in range(w - 1):
        d = y[2 * j] - y[2 * j + 2]
        if d > 0.0:
            s[j + 1], g[j + 1] = contact_slopes(d, y[2 * j + 1] - y[2 * j + 3], lo + j, n, ct)
        else:
            s[j + 1], g[j + 1] = 0.0, 0.0
    d = y[2 * w - 2] if wall else 0.0  # the wall ahead
    if d > 0.0:
        s[w], g[w] = contact_slopes(d, y[2 * w - 1], lo + w - 1, n, ct)
    else:
        s[w], g[w] = 0.0, 0.0
    for j in range(w):
        band[1, j], band[2, j] = onsite_slopes(y[2 * j], y[2 * j + 1], lo + j, exps, coef)
        band[6, j] = inverse_mass(lo + j, ct)
    return ft


@njit(**NO_NRT)
def factor(hg, w, band, ct):
    """LU (Thomas) of the tridiagonal system in K_v left by eliminating K_x = hg (r_x + K_v) from
    (1/hg - J) K = r: band[3] the inverse pivots, band[4] the normalised super-diagonal.
    False when a pivot is not finite or zero (the step is then rejected). With a contact term or masses
    the couplings are (hg dF/dd + dF/dw) / m (factor_terms)."""
    if has_terms(ct):
        return factor_terms(hg, w, band)
    s, dfx, dfv, dinv, cp = band[0], band[1], band[2], band[3], band[4]
    prev = 0.0
    for j in range(w):
        b = 1.0 / hg - dfv[j] + hg * (s[j] + s[j + 1] - dfx[j])
        if j > 0:
            b -= -hg * s[j] * prev
        if not (np.isfinite(b) and b != 0.0):
            return False
        dinv[j] = 1.0 / b
        prev = -hg * s[j + 1] * dinv[j] if j < w - 1 else 0.0
        cp[j] = prev
    return True


@njit(**NO_NRT)
def factor_terms(hg, w, band):
    """factor with damping band[5] (dF/dw per contact) and inverse masses band[6]: row j of (1/hg - J)
    after eliminating K_x has sub-, main and super-diagonal -(hg s_j + g_j)/m_j,
    1/hg + (hg (s_j + s_(j+1) - dfx_j) + g_j + g_(j+1) - dfv_j)/m_j, -(hg s_(j+1) + g_(j+1))/m_j."""
    s, dfx, dfv, dinv, cp, g, mi = band[0], band[1], band[2], band[3], band[4], band[5], band[6]
    prev = 0.0
    for j in range(w):
        b = 1.0 / hg + (hg * (s[j] + s[j + 1] - dfx[j]) + g[j] + g[j + 1] - dfv[j]) * mi[j]
        if j > 0:
            b += (hg * s[j] + g[j]) * mi[j] * prev
        if not (np.isfinite(b) and b != 0.0):
            return False
        dinv[j] = 1.0 / b
        prev = -(hg * s[j + 1] + g[j + 1]) * mi[j] * dinv[j] if j < w - 1 else 0.0
        cp[j] = prev
    return True


@njit(**NO_NRT)
def solve(r, k, hg, w, band, ct):
    """K from (1/hg - J) K = r with factor's LU (interleaved r, K; O(w))."""
    s, dfx, dinv, cp = band[0], band[1], band[3], band[4]
    terms = has_terms(ct)
    g, mi = band[5], band[6]
    prev = 0.0
    for j in range(w):
        if terms:
            rx = (dfx[j] - s[j] - s[j + 1]) * r[2 * j]
            if j > 0:
                rx += s[j] * r[2 * j - 2]
            if j < w - 1:
                rx += s[j + 1] * r[2 * j + 2]
            rhs_v = r[2 * j + 1] + hg * mi[j] * rx
            prev = (rhs_v + (hg * s[j] + g[j]) * mi[j] * prev) * dinv[j] if j > 0 else rhs_v * dinv[j]
        else:
            rhs_v = r[2 * j + 1] + hg * (dfx[j] - s[j] - s[j + 1]) * r[2 * j]
            if j > 0:
                rhs_v += hg * s[j] * r[2 * j - 2]
            if j < w - 1:
                rhs_v += hg * s[j + 1] * r[2 * j + 2]
            prev = (rhs_v + hg * s[j] * prev) * dinv[j] if j > 0 else rhs_v * dinv[j]
        k[2 * j + 1] = prev
    for j in range(w - 2, -1, -1):
        k[2 * j + 1] -= cp[j] * k[2 * j + 3]
    for j in range(w):
        k[2 * j] = hg * (r[2 * j] + k[2 * j + 1])


@njit(**NO_NRT)
def rosenbrock_step(t, h, y, f, yn, err, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct, k, work, band):
    """One Rodas4 step from (t, y) with f = f(t, y): yn and the error estimate err (= K_6).
    False when the linear system is singular. ``k``: (STAGES, >= 2w), ``work``: (3, >= 2w) scratch."""
    w2 = 2 * w
    r, ys, fy = work[0], work[1], work[2]
    hg = GAMMA * h
    ft = jacobian(t, y, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct, band)
    if not factor(hg, w, band, ct):
        return False
    for s in range(STAGES):
        if s == 0:
            for i in range(w2):
                fy[i] = f[i]
        else:
            for i in range(w2):
                acc = y[i]
                for j in range(s):
                    acc += A[s, j] * k[j, i]
                ys[i] = acc
            rhs(t + ALPHA[s] * h, ys, fy, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)
        for i in range(w2):
            acc = fy[i]
            for j in range(s):
                acc += C[s, j] / h * k[j, i]
            r[i] = acc
        r[1] += GAMMAS[s] * h * ft
        solve(r, k[s], hg, w, band, ct)
    for i in range(w2):
        acc = y[i]
        for s in range(STAGES):
            acc += M[s] * k[s, i]
        yn[i] = acc
        err[i] = k[STAGES - 1, i]
    return True


@njit(cache=True)
def run(y, f, fs, st, cf, ci, peaks, times, pulse_e, total_e, vpeaks, exps, coef, ct):
    """compiled_kernel.run with Rodas4 steps (same arguments, state and stop codes; st[NJEV] counts
    the Jacobians, one per attempted step). Step control: h_new = h min(6, max(0.2, 0.9 err^(-1/4))),
    no growth right after a rejection. Allocates the scratch arrays, then ``steps`` (compiled without
    reference counting) does the work."""
    cap = ci[CAPACITY]
    return steps(y, f, fs, st, cf, ci, peaks, times, pulse_e, total_e, vpeaks, *lean(exps, coef, ct),
                 np.empty((10, 2 * cap)), np.empty((7, cap + 1)), np.empty((STAGES, 2 * cap)), np.empty((4, 2 * cap)))


@njit(**NO_NRT)
def steps(y, f, fs, st, cf, ci, peaks, times, pulse_e, total_e, vpeaks, exps, coef, ct, work, band, k, rc):
    """The steps of ``run`` (scratch: ``work`` 10 rows of 2 x ci[CAPACITY], ``band`` the banded
    Jacobian 7 x (ci[CAPACITY] + 1), ``k`` the stages, ``rc`` the dense output's 4 rows)."""
    n = cf[EXP]
    rtol, atol = cf[RTOL], cf[ATOL]
    yn, fn, err_v, pk = work[6], work[7], work[8], work[9]
    start(fs[T], y, f, st, fs, cf, ci, exps, coef, ct, work)
    t, h = fs[T], fs[H]
    while True:
        h, code = next_step(t, h, st, fs, cf, ci)
        if code != 0:
            return code
        st[NJEV] += 1
        lo, w, wall, has_left, w2, lx, lv, lt = window_now(st, fs, ci)
        err = np.inf
        if rosenbrock_step(t, h, y, f, yn, err_v, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct, k, work, band):
            st[NFEV] += STAGES - 1
            err = 0.0
            for i in range(w2):
                e = err_v[i] / (atol + rtol * max(abs(y[i]), abs(yn[i])))
                err += e * e
            err = np.sqrt(err / w2)
        if err != err:  # NaN: a stage met a non-finite force; t and h kept for compiled.py to locate it
            fs[T], fs[H] = t, h
            return NONFINITE
        if not np.isfinite(err):
            fac = FAC_MIN
        else:
            fac = FAC_MAX if err == 0.0 else min(FAC_MAX, max(FAC_MIN, SAFE * err ** (-1.0 / ORDER)))
        if not err <= 1.0:  # rejected (NaN and a singular system included)
            h = h * min(fac, SAFE)
            st[REJECTED] = 1
            continue
        if st[REJECTED] == 1:
            fac = min(fac, 1.0)
        st[REJECTED] = 0
        h_new = h * fac
        t_old = t
        t = t + h
        rhs(t, yn, fn, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)
        st[NFEV] += 1
        if peak_in_step(y, yn, f, fn, st, ci, vpeaks):
            hermite_dense(rc, y, yn, f, fn, h, w2)
        code = track_step(t_old, t, h, y, yn, rc, pk, w, st, fs, cf, ci, peaks, times, pulse_e, total_e, ct,
                          f, fn, vpeaks)
        code = finish_step(t, h_new, y, f, yn, fn, w, st, fs, cf, ci, exps, coef, ct, code)  # fn = f(t, yn)
        h = h_new
        if code != 0:
            return code
