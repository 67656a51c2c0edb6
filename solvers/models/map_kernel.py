"""Compiled iteration of the amplitude map (Eq. 23) from its power-term table.

Every variant of Eq. 23 has the same shape (derive/amplitude_map.py):

    F1 = f1 A_{i-1}^P - 2 f2 A_i^P + f3 A_{i+1}^P + eps sum_k K1_k A_i^{p_k}
    F2 = alpha A_i^P - beta A_{i+1}^P             + eps sum_k K2_k A_{i+1}^{q_k}

(``1d``: A_{i+1} -> A_i in F1, F2 unused), so one compiled kernel, given the powers and the
per-contact coefficients K (the generated module's ``map_power_coefficients``), iterates any R:
a new R costs no compilation. Newton runs in log-amplitudes with the same damping, iteration
cap and stopping rule as ``map_step._newton``; a contact where Newton fails is handed back
(``stopped``) so the caller can finish it with the bracketing fallback.
"""

from __future__ import annotations

import math

import numpy as np
from pulsemap.solvers.chain.jit import njit

Array = np.ndarray

#: Newton's iteration cap and step tolerance (the same as map_step._newton).
NEWTON_ITERATIONS = 60
NEWTON_STEP_TOL = 1e-13


@njit(cache=True, inline="always")
def _forcing(la: float, powers: Array, coef: Array) -> tuple[float, float]:
    """(sum_k K_k A^p_k, sum_k p_k K_k A^p_k) at log-amplitude la: a forcing sum and its log-derivative."""
    s = 0.0
    ds = 0.0
    for k in range(powers.size):
        term = coef[k] * math.exp(powers[k] * la)
        s += term
        ds += powers[k] * term
    return s, ds


@njit(cache=True)
def _step(a_prev: float, g0: float, g1: float, two: bool, P: float, f1: float, f2: float, f3: float,
          alpha: float, beta: float, eps: float, p1: Array, k1: Array, p2: Array, k2: Array):
    """One contact: Newton for (A_i, A_{i+1}) from the guess (g0, g1); ok False when it fails."""
    x0 = math.log(g0)
    x1 = math.log(g1)
    c_prev = f1 * a_prev ** P
    for _ in range(NEWTON_ITERATIONS):
        a = math.exp(x0)
        aP = math.exp(P * x0)
        s1, ds1 = _forcing(x0, p1, k1)
        if two:
            b = math.exp(x1)
            bP = math.exp(P * x1)
            s2, ds2 = _forcing(x1, p2, k2)
            F1 = c_prev - 2.0 * f2 * aP + f3 * bP + eps * s1
            F2 = alpha * aP - beta * bP + eps * s2
            j11 = -2.0 * f2 * P * aP + eps * ds1
            j12 = f3 * P * bP
            j21 = alpha * P * aP
            j22 = -beta * P * bP + eps * ds2
            det = j11 * j22 - j12 * j21
            if det == 0.0 or not math.isfinite(det):
                return a, b, False
            d0 = (F1 * j22 - F2 * j12) / det
            d1 = (F2 * j11 - F1 * j21) / det
        else:
            F1 = c_prev - (2.0 * f2 - f3) * aP + eps * s1
            j11 = -(2.0 * f2 - f3) * P * aP + eps * ds1
            if j11 == 0.0 or not math.isfinite(j11):
                return a, a, False
            d0 = F1 / j11
            d1 = 0.0
        big = max(abs(d0), abs(d1))
        if not math.isfinite(big):
            return a, a, False
        damp = 1.0 if big < 0.5 else 0.5 / big
        x0 -= damp * d0
        x1 -= damp * d1
        if big < NEWTON_STEP_TOL:
            a = math.exp(x0)
            return a, (math.exp(x1) if two else a), True
    return math.exp(x0), math.exp(x1), False


@njit(cache=True)
def iterate_table(a0: float, g0: float, g1: float, steps: int, two: bool, P: float, f1: float, f2: float,
                  f3: float, alpha: float, beta: float, eps: float, p1: Array, K1: Array, p2: Array, K2: Array,
                  a_min: float, out_A: Array, out_ratio: Array) -> tuple[int, int, float, float]:
    """Iterate ``steps`` contacts from A = a0 (K1, K2: one row of coefficients per contact).

    Fills out_A and out_ratio (the forcing ratio |F1(A, A, A)| / (f1 A^P)) and returns
    (contacts done, status, last guess g0, g1): status 0 ok, 1 Newton failed at the next
    contact, 2 no positive/finite amplitude, 3 died (A below ``a_min``).
    """
    a_prev = a0
    rows1 = K1.shape[0]
    rows2 = K2.shape[0]
    for k in range(steps):
        k1 = K1[k if rows1 > 1 else 0]
        k2 = K2[k if rows2 > 1 else 0]
        a, b, ok = _step(a_prev, g0, g1, two, P, f1, f2, f3, alpha, beta, eps, p1, k1, p2, k2)
        if not ok:
            return k, 1, g0, g1
        if not (math.isfinite(a) and a > 0.0 and math.isfinite(b) and b > 0.0):
            return k, 2, g0, g1
        if a < a_min:
            return k, 3, g0, g1
        s1, _ = _forcing(math.log(a), p1, k1)
        aP = a ** P
        out_A[k] = a
        out_ratio[k] = abs((f1 - 2.0 * f2 + f3) * aP + eps * s1) / (f1 * aP)
        r = a / a_prev
        g0 = a * r
        g1 = b * r
        a_prev = a
    return steps, 0, g0, g1
