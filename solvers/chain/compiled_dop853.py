"""numba kernel: moving-window DOP853 integration of paper Eq. 1 with peak tracking (method "DOP853").

    x_i'' = (x_{i-1} - x_i)_+^n - (x_i - x_{i+1})_+^n + F_i(x_i, x_i')                (paper Eq. 1)

Hairer's explicit Runge-Kutta 8(5,3) (Hairer, Norsett & Wanner, Solving ODEs I, sec. II.10; the
tableau of dop853.f, as scipy's dop853_coefficients), on the same window, force data, peaks and
stop rules as the Dormand-Prince 5(4) kernel (compiled_kernel.py), which it mirrors step for step.
Step control as dop853.f's defaults: err = |h| err5^2 / sqrt(w2 (err5^2 + 0.01 err3^2)) over the
window's 2w components (err5, err3: the 5th- and 3rd-order estimators, scaled by atol + rtol |y|),
h_new = h / max(1/6, min(1/0.333, err^(1/8) / 0.9)); a rejected step shrinks by the same rule. The
first step is compiled_kernel's (HINIT). 12 right-hand sides per accepted step (11 stages and the
new point's, which starts the next step), 3 more in a step where a contact peaks: the dense output
of order 7 (compiled_track's nested form with 7 rows), on which the peak is located and valued.

Where it pays: between the rare openings of contacts a damped pulse is smooth, and order 8 reaches
1e-6 peak error at about half the cost of order 5 (fig8-eps0.1); where the wake keeps closing and
reopening contacts (Van der Pol), every (.)_+^(3/2) kink caps the step and order 5 is ~3x cheaper.
Hence opt-in (simulate(..., integrator=Integrator(method="DOP853"))), not the default.
"""

# numba cache stamp: b6266238713c7034
from __future__ import annotations

import numpy as np
from pulsemap.solvers.chain.jit import njit

from pulsemap.solvers.chain.compiled_force import lean
from pulsemap.solvers.chain.compiled_ops import NO_NRT, rhs
from pulsemap.solvers.chain.compiled_layout import ATOL, CAPACITY, EXP, H, NFEV, NONFINITE, REJECTED, RTOL, T
from pulsemap.solvers.chain.compiled_track import start, finish_step, next_step, peak_in_step, track_step, window_now

METHOD = "DOP853"
SAFE, FAC1, FAC2 = 0.9, 0.333, 6.0  # dop853.f's defaults (BETA = 0: no PI term)
DENSE_ROWS = 7  # rows of the dense output (compiled_track.dense_value)

# --- the tableau (16 stages: 12 of the step, the new point's f as stage 12, 3 for the dense output)
A = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.05260015195876773, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.0197250569845379, 0.0591751709536137, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.02958758547680685, 0.0, 0.08876275643042054, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.2413651341592667, 0.0, -0.8845494793282861, 0.924834003261792, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
     0.0, 0.0, 0.0],
    [0.037037037037037035, 0.0, 0.0, 0.17082860872947386, 0.12546768756682242, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
     0.0, 0.0, 0.0, 0.0],
    [0.037109375, 0.0, 0.0, 0.17025221101954405, 0.06021653898045596, -0.017578125, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
     0.0, 0.0, 0.0, 0.0],
    [0.03709200011850479, 0.0, 0.0, 0.17038392571223998, 0.10726203044637328, -0.015319437748624402,
     0.008273789163814023, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.6241109587160757, 0.0, 0.0, -3.3608926294469414, -0.868219346841726, 27.59209969944671, 20.154067550477894,
     -43.48988418106996, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.47766253643826434, 0.0, 0.0, -2.4881146199716677, -0.590290826836843, 21.230051448181193, 15.279233632882423,
     -33.28821096898486, -0.020331201708508627, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [-0.9371424300859873, 0.0, 0.0, 5.186372428844064, 1.0914373489967295, -8.149787010746927, -18.52006565999696,
     22.739487099350505, 2.4936055526796523, -3.0467644718982196, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [2.273310147516538, 0.0, 0.0, -10.53449546673725, -2.0008720582248625, -17.9589318631188, 27.94888452941996,
     -2.8589982771350235, -8.87285693353063, 12.360567175794303, 0.6433927460157636, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.054293734116568765, 0.0, 0.0, 0.0, 0.0, 4.450312892752409, 1.8915178993145003, -5.801203960010585,
     0.3111643669578199, -0.1521609496625161, 0.20136540080403034, 0.04471061572777259, 0.0, 0.0, 0.0, 0.0],
    [0.056167502283047954, 0.0, 0.0, 0.0, 0.0, 0.0, 0.25350021021662483, -0.2462390374708025, -0.12419142326381637,
     0.15329179827876568, 0.00820105229563469, 0.007567897660545699, -0.008298, 0.0, 0.0, 0.0],
    [0.03183464816350214, 0.0, 0.0, 0.0, 0.0, 0.028300909672366776, 0.053541988307438566, -0.05492374857139099, 0.0,
     0.0, -0.00010834732869724932, 0.0003825710908356584, -0.00034046500868740456, 0.1413124436746325, 0.0, 0.0],
    [-0.42889630158379194, 0.0, 0.0, 0.0, 0.0, -4.697621415361164, 7.683421196062599, 4.06898981839711,
     0.3567271874552811, 0.0, 0.0, 0.0, -0.0013990241651590145, 2.9475147891527724, -9.15095847217987, 0.0],
])
C = np.array([0.0, 0.05260015195876773, 0.0789002279381516, 0.1183503419072274, 0.2816496580927726,
              0.3333333333333333, 0.25, 0.3076923076923077, 0.6512820512820513, 0.6, 0.8571428571428571, 1.0, 1.0,
              0.1, 0.2, 0.7777777777777778])
E5 = np.array([0.01312004499419488, 0.0, 0.0, 0.0, 0.0, -1.2251564463762044, -0.4957589496572502, 1.6643771824549864,
               -0.35032884874997366, 0.3341791187130175, 0.08192320648511571, -0.022355307863886294])
E3 = np.array([-0.18980075407240762, 0.0, 0.0, 0.0, 0.0, 4.450312892752409, 1.8915178993145003, -5.801203960010585,
               -0.4226823213237919, -0.1521609496625161, 0.20136540080403034, 0.02265179219836082])
D = np.array([
    [-8.428938276109013, 0.0, 0.0, 0.0, 0.0, 0.5667149535193777, -3.0689499459498917, 2.38466765651207,
     2.117034582445028, -0.871391583777973, 2.2404374302607883, 0.6315787787694688, -0.08899033645133331,
     18.148505520854727, -9.194632392478356, -4.436036387594894],
    [10.427508642579134, 0.0, 0.0, 0.0, 0.0, 242.28349177525817, 165.20045171727028, -374.5467547226902,
     -22.113666853125306, 7.733432668472264, -30.674084731089398, -9.332130526430229, 15.697238121770845,
     -31.139403219565178, -9.35292435884448, 35.81684148639408],
    [19.985053242002433, 0.0, 0.0, 0.0, 0.0, -387.0373087493518, -189.17813819516758, 527.8081592054236,
     -11.57390253995963, 6.8812326946963, -1.0006050966910838, 0.7777137798053443, -2.778205752353508,
     -60.19669523126412, 84.32040550667716, 11.99229113618279],
    [-25.69393346270375, 0.0, 0.0, 0.0, 0.0, -154.18974869023643, -231.5293791760455, 357.6391179106141,
     93.40532418362432, -37.45832313645163, 104.0996495089623, 29.8402934266605, -43.53345659001114,
     96.32455395918828, -39.17726167561544, -149.72683625798564],
])


@njit(**NO_NRT)
def dense_output(rc, h, y, yn, f, k1, k2, k3, k4, k5, k6, k7, k8, k9, k10, k11, k12, k13, k14, k15, ys, w, lo, n,
                 has_left, lx, lv, lt, wall, t, exps, coef, ct):
    """The order-7 dense output's rows of the step t -> t + h (stages 13-15 evaluated here; k12 = f(t + h, yn))."""
    w2 = 2 * w
    for i in range(w2):
        ys[i] = y[i] + h * (A[13, 0] * f[i] + A[13, 6] * k6[i] + A[13, 7] * k7[i] + A[13, 8] * k8[i] +
                            A[13, 9] * k9[i] + A[13, 10] * k10[i] + A[13, 11] * k11[i] + A[13, 12] * k12[i])
    rhs(t + C[13] * h, ys, k13, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)
    for i in range(w2):
        ys[i] = y[i] + h * (A[14, 0] * f[i] + A[14, 5] * k5[i] + A[14, 6] * k6[i] + A[14, 7] * k7[i] +
                            A[14, 10] * k10[i] + A[14, 11] * k11[i] + A[14, 12] * k12[i] + A[14, 13] * k13[i])
    rhs(t + C[14] * h, ys, k14, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)
    for i in range(w2):
        ys[i] = y[i] + h * (A[15, 0] * f[i] + A[15, 5] * k5[i] + A[15, 6] * k6[i] + A[15, 7] * k7[i] +
                            A[15, 8] * k8[i] + A[15, 12] * k12[i] + A[15, 13] * k13[i] + A[15, 14] * k14[i])
    rhs(t + C[15] * h, ys, k15, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)
    for i in range(w2):
        dy = yn[i] - y[i]
        rc[0, i] = dy
        rc[1, i] = h * f[i] - dy
        rc[2, i] = 2.0 * dy - h * (k12[i] + f[i])
        rc[3, i] = h * (D[0, 0] * f[i] + D[0, 5] * k5[i] + D[0, 6] * k6[i] + D[0, 7] * k7[i] + D[0, 8] * k8[i] +
                        D[0, 9] * k9[i] + D[0, 10] * k10[i] + D[0, 11] * k11[i] + D[0, 12] * k12[i] +
                        D[0, 13] * k13[i] + D[0, 14] * k14[i] + D[0, 15] * k15[i])
        rc[4, i] = h * (D[1, 0] * f[i] + D[1, 5] * k5[i] + D[1, 6] * k6[i] + D[1, 7] * k7[i] + D[1, 8] * k8[i] +
                        D[1, 9] * k9[i] + D[1, 10] * k10[i] + D[1, 11] * k11[i] + D[1, 12] * k12[i] +
                        D[1, 13] * k13[i] + D[1, 14] * k14[i] + D[1, 15] * k15[i])
        rc[5, i] = h * (D[2, 0] * f[i] + D[2, 5] * k5[i] + D[2, 6] * k6[i] + D[2, 7] * k7[i] + D[2, 8] * k8[i] +
                        D[2, 9] * k9[i] + D[2, 10] * k10[i] + D[2, 11] * k11[i] + D[2, 12] * k12[i] +
                        D[2, 13] * k13[i] + D[2, 14] * k14[i] + D[2, 15] * k15[i])
        rc[6, i] = h * (D[3, 0] * f[i] + D[3, 5] * k5[i] + D[3, 6] * k6[i] + D[3, 7] * k7[i] + D[3, 8] * k8[i] +
                        D[3, 9] * k9[i] + D[3, 10] * k10[i] + D[3, 11] * k11[i] + D[3, 12] * k12[i] +
                        D[3, 13] * k13[i] + D[3, 14] * k14[i] + D[3, 15] * k15[i])


@njit(cache=True)
def run(y, f, fs, st, cf, ci, peaks, times, pulse_e, total_e, vpeaks, exps, coef, ct):
    """Integrate until a stop rule fires; returns its code (state in y, f, fs, st for a resume), as
    compiled_kernel.run (same bookkeeping after each accepted step: compiled_track). Allocates the
    scratch arrays, then ``steps`` (compiled without reference counting) does the work."""
    cap = ci[CAPACITY]
    return steps(y, f, fs, st, cf, ci, peaks, times, pulse_e, total_e, vpeaks, *lean(exps, coef, ct),
                 np.empty((18, 2 * cap)), np.empty((DENSE_ROWS, 2 * cap)))


@njit(**NO_NRT)
def steps(y, f, fs, st, cf, ci, peaks, times, pulse_e, total_e, vpeaks, exps, coef, ct, work, rc):
    """The steps of ``run`` (``work``: 18 rows of scratch, ``rc``: the dense output's DENSE_ROWS rows,
    each of 2 x ci[CAPACITY])."""
    n = cf[EXP]
    rtol, atol = cf[RTOL], cf[ATOL]
    k1, k2, k3, k4, k5, k6, k7, k8 = work[0], work[1], work[2], work[3], work[4], work[5], work[9], work[10]
    k9, k10, k11, k12, k13, k14, k15 = work[11], work[12], work[13], work[14], work[15], work[16], work[17]
    ys, yn, scratch = work[6], work[7], work[8]  # start() uses rows 6-8 before the first step
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
            ys[i] = y[i] + h * (A[1, 0] * f[i])
        rhs(t + C[1] * h, ys, k1, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)
        for i in range(w2):
            ys[i] = y[i] + h * (A[2, 0] * f[i] + A[2, 1] * k1[i])
        rhs(t + C[2] * h, ys, k2, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)
        for i in range(w2):
            ys[i] = y[i] + h * (A[3, 0] * f[i] + A[3, 2] * k2[i])
        rhs(t + C[3] * h, ys, k3, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)
        for i in range(w2):
            ys[i] = y[i] + h * (A[4, 0] * f[i] + A[4, 2] * k2[i] + A[4, 3] * k3[i])
        rhs(t + C[4] * h, ys, k4, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)
        for i in range(w2):
            ys[i] = y[i] + h * (A[5, 0] * f[i] + A[5, 3] * k3[i] + A[5, 4] * k4[i])
        rhs(t + C[5] * h, ys, k5, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)
        for i in range(w2):
            ys[i] = y[i] + h * (A[6, 0] * f[i] + A[6, 3] * k3[i] + A[6, 4] * k4[i] + A[6, 5] * k5[i])
        rhs(t + C[6] * h, ys, k6, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)
        for i in range(w2):
            ys[i] = y[i] + h * (A[7, 0] * f[i] + A[7, 3] * k3[i] + A[7, 4] * k4[i] + A[7, 5] * k5[i] +
                                A[7, 6] * k6[i])
        rhs(t + C[7] * h, ys, k7, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)
        for i in range(w2):
            ys[i] = y[i] + h * (A[8, 0] * f[i] + A[8, 3] * k3[i] + A[8, 4] * k4[i] + A[8, 5] * k5[i] + A[8, 6] * k6[i] +
                                A[8, 7] * k7[i])
        rhs(t + C[8] * h, ys, k8, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)
        for i in range(w2):
            ys[i] = y[i] + h * (A[9, 0] * f[i] + A[9, 3] * k3[i] + A[9, 4] * k4[i] + A[9, 5] * k5[i] + A[9, 6] * k6[i] +
                                A[9, 7] * k7[i] + A[9, 8] * k8[i])
        rhs(t + C[9] * h, ys, k9, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)
        for i in range(w2):
            ys[i] = y[i] + h * (A[10, 0] * f[i] + A[10, 3] * k3[i] + A[10, 4] * k4[i] + A[10, 5] * k5[i] +
                                A[10, 6] * k6[i] + A[10, 7] * k7[i] + A[10, 8] * k8[i] + A[10, 9] * k9[i])
        rhs(t + C[10] * h, ys, k10, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)
        for i in range(w2):
            ys[i] = y[i] + h * (A[11, 0] * f[i] + A[11, 3] * k3[i] + A[11, 4] * k4[i] + A[11, 5] * k5[i] +
                                A[11, 6] * k6[i] + A[11, 7] * k7[i] + A[11, 8] * k8[i] + A[11, 9] * k9[i] +
                                A[11, 10] * k10[i])
        rhs(t + C[11] * h, ys, k11, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)
        for i in range(w2):
            yn[i] = y[i] + h * (A[12, 0] * f[i] + A[12, 5] * k5[i] + A[12, 6] * k6[i] + A[12, 7] * k7[i] +
                                A[12, 8] * k8[i] + A[12, 9] * k9[i] + A[12, 10] * k10[i] + A[12, 11] * k11[i])
        st[NFEV] += 11
        err5, err3 = 0.0, 0.0
        for i in range(w2):
            sk = atol + rtol * max(abs(y[i]), abs(yn[i]))
            e5 = (E5[0] * f[i] + E5[5] * k5[i] + E5[6] * k6[i] + E5[7] * k7[i] + E5[8] * k8[i] + E5[9] * k9[i] +
                  E5[10] * k10[i] + E5[11] * k11[i]) / sk
            e3 = (E3[0] * f[i] + E3[5] * k5[i] + E3[6] * k6[i] + E3[7] * k7[i] + E3[8] * k8[i] + E3[9] * k9[i] +
                  E3[10] * k10[i] + E3[11] * k11[i]) / sk
            err5 += e5 * e5
            err3 += e3 * e3
        deno = err5 + 0.01 * err3
        err = abs(h) * err5 / np.sqrt(w2 * (deno if deno > 0.0 else 1.0))
        fac11 = err**0.125 if err > 0.0 else 0.0
        if err != err:  # NaN: a stage met a non-finite force; t and h kept for compiled.py to locate it
            fs[T], fs[H] = t, h
            return NONFINITE
        if not err <= 1.0:  # rejected
            h = h / min(1.0 / FAC1, fac11 / SAFE)
            st[REJECTED] = 1
            continue
        h_new = h / max(1.0 / FAC2, min(1.0 / FAC1, fac11 / SAFE))
        if st[REJECTED] == 1:
            h_new = min(h_new, h)
        st[REJECTED] = 0
        t_old = t
        t = t + h
        rhs(t, yn, k12, w, lo, n, has_left, lx, lv, lt, wall, exps, coef, ct)  # f at the new point: next step's f
        st[NFEV] += 1
        if peak_in_step(y, yn, f, k12, st, ci, vpeaks):
            dense_output(rc, h, y, yn, f, k1, k2, k3, k4, k5, k6, k7, k8, k9, k10, k11, k12, k13, k14, k15, ys, w, lo,
                         n, has_left, lx, lv, lt, wall, t_old, exps, coef, ct)
            st[NFEV] += 3
        code = track_step(t_old, t, h, y, yn, rc, scratch, w, st, fs, cf, ci, peaks, times, pulse_e, total_e, ct,
                          f, k12, vpeaks)
        code = finish_step(t, h_new, y, f, yn, k12, w, st, fs, cf, ci, exps, coef, ct, code)
        h = h_new
        if code != 0:
            return code
