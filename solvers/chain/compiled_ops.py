"""numba building blocks of the compiled DNS of paper Eq. 1 (used by compiled_kernel.py).

    x_i'' = (x_{i-1} - x_i)_+^n - (x_i - x_{i+1})_+^n + sum_m c_m[i] x_i^(a_m) v_i^(b_m)     (Eq. 1)

The right-hand side on a window with a coasting left bead and a wall, the window's energies, the
Dormand-Prince 5(4) tableau and its dense output's coefficients, and the pulse-loss rule of
peaks.primary_pulse_lost.
"""

# numba cache stamp: b6266238713c7034
from __future__ import annotations

from pulsemap.solvers.chain.jit import njit

from pulsemap.solvers.chain.compiled_force import (add_onsite, add_tail, inverse_mass, kinetic, pos_pow, push,
                                                    tail_force, tail_start)

# --- Dormand-Prince 5(4) (Hairer & Wanner's DOPRI5), dense output of order 4 (CONTD5)
C2, C3, C4, C5 = 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0
A21 = 1.0 / 5.0
A31, A32 = 3.0 / 40.0, 9.0 / 40.0
A41, A42, A43 = 44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0
A51, A52, A53, A54 = 19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0
A61, A62, A63, A64, A65 = 9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0, -5103.0 / 18656.0
A71, A73, A74, A75, A76 = 35.0 / 384.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0
E1, E3, E4, E5, E6, E7 = (71.0 / 57600.0, -71.0 / 16695.0, 71.0 / 1920.0, -17253.0 / 339200.0,
                          22.0 / 525.0, -1.0 / 40.0)
D1, D3, D4, D5, D6, D7 = (-12715105075.0 / 11282082432.0, 87487479700.0 / 32700410799.0,
                          -10690763975.0 / 1880347072.0, 701980252875.0 / 199316789632.0,
                          -1453857185.0 / 822651844.0, 69997945.0 / 29380423.0)
BETA = 0.04  # PI control (Hairer's DOPRI5 default, also solvers/chain/hairer.FORTRAN_BETA["dopri5"])
SAFE, FAC_MIN, FAC_MAX = 0.9, 0.2, 10.0
PULSE_HALF_WIDTH = 8  # front.PULSE_HALF_WIDTH (beads each side of a peaked contact carrying the pulse)


def _no_nrt_options() -> dict:
    """NO_NRT: numba's private ``_nrt`` flag where this numba knows it (0.59-0.68 do), else plain
    caching (the same numbers, a quarter slower): an unknown option would fail at the first call."""
    try:
        from numba.core.cpu import CPUTargetOptions
        from numba.core.options import TargetOptions

        known = isinstance(getattr(CPUTargetOptions, "_nrt", None), TargetOptions.Mapping)
    except (ImportError, AttributeError):
        known = False
    return dict(cache=True, _nrt=False) if known else dict(cache=True)


#: numba options of every kernel function that allocates nothing: cached, and compiled without
#: reference counting (numba's increfs and decrefs of every array argument cost about a quarter of a
#: run: docs/dns.rst). Only each kernel's ``run`` allocates (its scratch arrays) and then calls its
#: loop, compiled with these options.
NO_NRT = _no_nrt_options()


@njit(cache=True, inline="always")
def _bead(j, prev, y, out, lo, n, exps, coef, ct, tail, uniform):
    """Bead j of the window but the last: its velocity and acceleration into out, returns the force it pushes
    bead j + 1 with (``uniform``, a constant: the bead is in the force's uniform tail, read from ``tail``)."""
    x = y[2 * j]
    v = y[2 * j + 1]
    fj = push(x - y[2 * j + 2], v - y[2 * j + 3], lo + j, n, ct)
    if uniform:
        acc = add_tail(prev - fj, x, v, lo + j, tail, exps, coef)
    else:
        acc = add_onsite(prev - fj, x, v, lo + j, exps, coef)
    out[2 * j] = v
    out[2 * j + 1] = acc * inverse_mass(lo + j, ct)
    return fj


@njit(cache=True, inline="always")
def _accelerations(t, y, out, w, lo, n, has_left, left_x, left_v, left_t, wall, exps, coef, ct):
    """rhs's loops over the beads (inlined twice by rhs: n a constant 1.5 in one): the beads with a force of
    their own, then those of the force's uniform tail (its coefficients read once), then the last bead."""
    if w == 0:
        return
    prev = push(left_x + left_v * (t - left_t) - y[0], left_v - y[1], lo - 1, n, ct) if has_left else 0.0
    tail = tail_force(exps, coef)
    split = max(min(tail_start(exps, coef) - lo, w - 1), 0)  # >= 0 as written: no negative-index test per bead
    for j in range(split):
        prev = _bead(j, prev, y, out, lo, n, exps, coef, ct, tail, False)
    for j in range(split, w - 1):
        prev = _bead(j, prev, y, out, lo, n, exps, coef, ct, tail, True)
    j = w - 1  # the last bead: against the wall at rest, or free
    x = y[2 * j]
    v = y[2 * j + 1]
    fj = push(x, v, lo + j, n, ct) if wall else 0.0
    out[2 * j] = v
    out[2 * j + 1] = add_onsite(prev - fj, x, v, lo + j, exps, coef) * inverse_mass(lo + j, ct)


@njit(**NO_NRT)
def rhs(t, y, out, w, lo, n, has_left, left_x, left_v, left_t, wall, exps, coef, ct):
    """Eq. 1 on the window's w beads (interleaved), the on-site force (exps, coef), the contact law's term
    and the masses (ct) as compiled_force.py reads them:
    m_j x_j'' = F(d_(j-1), w_(j-1)) - F(d_j, w_j) + F_j(x_j, v_j)."""
    if n == 1.5:  # the Hertz exponent as a constant: d^n by a square root, without a test of n per bead
        _accelerations(t, y, out, w, lo, 1.5, has_left, left_x, left_v, left_t, wall, exps, coef, ct)
    else:
        _accelerations(t, y, out, w, lo, n, has_left, left_x, left_v, left_t, wall, exps, coef, ct)


@njit(**NO_NRT)
def window_energy(t, y, w, n, has_left, left_x, left_v, left_t, lo, ct):
    """Kinetic + Hertz contact energy of the window (with the contact to the coasting left bead; the
    contact law's term P is left out: the energy is the blow-up guard's, and a drift is reported only
    for a conservative chain)."""
    e = 0.0
    for j in range(w):
        e += kinetic(y[2 * j + 1], lo + j, ct)
        if j < w - 1:
            d = y[2 * j] - y[2 * j + 2]
            if d > 0.0:
                e += pos_pow(d, n) * d / (n + 1.0)
    if has_left:
        d = left_x + left_v * (t - left_t) - y[0]
        if d > 0.0:
            e += pos_pow(d, n) * d / (n + 1.0)
    return e


@njit(**NO_NRT)
def segment_energy(y, a, b, n, lo, ct):
    """Kinetic + contact energy of local beads a..b-1 and the contacts between them (front.py)."""
    e = 0.0
    for j in range(a, b):
        e += kinetic(y[2 * j + 1], lo + j, ct)
        if j < b - 1:
            d = y[2 * j] - y[2 * j + 2]
            if d > 0.0:
                e += pos_pow(d, n) * d / (n + 1.0)
    return e


@njit(**NO_NRT)
def hermite_dense(rc, y0, y1, f0, f1, h, w2):
    """Dense-output coefficients (compiled_track.dense_value) of the cubic Hermite interpolant of
    (y0, f0) and (y1, f1): rc3 = 0, order 3 (the Rosenbrock kernel's)."""
    for i in range(w2):
        ydiff = y1[i] - y0[i]
        bspl = h * f0[i] - ydiff
        rc[0, i] = ydiff
        rc[1, i] = bspl
        rc[2, i] = ydiff - h * f1[i] - bspl
        rc[3, i] = 0.0


@njit(**NO_NRT)
def dopri_dense(rc, y0, y1, h, k1, k3, k4, k5, k6, k7, w2):
    """The DOPRI5 dense output's coefficients (Hairer's CONTD5: the Hermite cubic plus rc3, order 4)."""
    hermite_dense(rc, y0, y1, k1, k7, h, w2)
    for i in range(w2):
        rc[3, i] = h * (D1 * k1[i] + D3 * k3[i] + D4 * k4[i] + D5 * k5[i] + D6 * k6[i] + D7 * k7[i])


@njit(**NO_NRT)
def pulse_lost(peaks, times, k, first, death_fraction, overtake, delay_factor):
    """solvers.peaks.primary_pulse_lost as a code: 0 alive, 1 died, 2 overtaken, 3 stopped travelling."""
    if k < first:
        return 0
    value = peaks[k - 1]
    if value < death_fraction * peaks[first - 1]:
        return 1
    if k > first and value > overtake * peaks[k - 2]:
        return 2
    if k >= 3 and k - 2 >= first:
        before = times[k - 2] - times[k - 3]
        now = times[k - 1] - times[k - 2]
        if before > 0.0 and now > delay_factor * before:
            return 3
    return 0
