"""The right-hand side of the dressed law's expansion about the exact wave, compiled (models/dressed_expansion.py, part 1).

``expansion_rhs`` is the first- and second-order equations of Eq. 1 expanded in c (models/dressed_expansion.py's
module docstring) with the wave x0 evaluated in place by its quintic Hermite interpolant (``WaveBase``):
the same arithmetic as the numpy form, in one compiled call per evaluation instead of ~60 numpy calls.
"""

from __future__ import annotations

import math

import numpy as np

from pulsemap.solvers.chain.jit import njit


@njit(cache=True)
def wave(t, nodes, h, tau0, centre, npu, coef, beads):  # pragma: no cover (compiled)
    """(d0, x0, v0) of the wave of scale 1 at time t (models/dressed_expansion.py, ``WaveBase.__call__``)."""
    pos = (t + centre - tau0) / h
    J = math.floor(pos)
    r = pos - J
    m = nodes.shape[0]
    w = np.zeros(6)
    dw = np.zeros(6)
    for c in range(6):
        p, dp = 1.0, 0.0
        for k in range(6):
            w[c] += p * coef[k, c]
            dw[c] += dp * coef[k, c]
            dp = (k + 1) * p / h
            p *= r
    scale = (1.0, h, h * h)
    d0 = np.zeros(beads - 1)
    dv = np.zeros(beads - 1)
    for j in range(beads - 1):
        idx = J - npu * (j + 1)
        if 0 <= idx <= m - 2:
            s, sv = 0.0, 0.0
            for q in range(3):
                s += nodes[idx, q] * scale[q] * w[q] + nodes[idx + 1, q] * scale[q] * w[q + 3]
                sv += nodes[idx, q] * scale[q] * dw[q] + nodes[idx + 1, q] * scale[q] * dw[q + 3]
            d0[j] = max(s, 0.0)
            dv[j] = sv
    x0 = np.zeros(beads)
    v0 = np.zeros(beads)
    for j in range(beads - 2, -1, -1):
        x0[j] = x0[j + 1] + d0[j]
        v0[j] = v0[j + 1] + dv[j]
    return d0, x0, v0


@njit(cache=True)
def _power(x, p):  # pragma: no cover (compiled)
    return 1.0 if p == 0 else x**p


@njit(cache=True)
def expansion_rhs(t, y, nodes, h, tau0, centre, npu, coef, beads, nn, floor, mask, monos, pairs):  # pragma: no cover
    """dY/dt of the expansion: rows 2j, 2j+1 the first order y_j, y_j' of monomial j (monos[j] = a, b), rows
    2(M+q), 2(M+q)+1 the second order z, z' of pair q (pairs[q] = j, l)."""
    M, P = monos.shape[0], pairs.shape[0]
    Y = y.reshape(2 * (M + P), beads)
    d0, x0, v0 = wave(t, nodes, h, tau0, centre, npu, coef, beads)
    F1 = np.empty(beads - 1)  # plain loops: array expressions and slice copies compile slowly
    F2 = np.empty(beads - 1)
    for i in range(beads - 1):
        F1[i] = nn * d0[i] ** (nn - 1)
        if floor != 0.0:  # F''(d0) tapered below the cut
            F2[i] = nn * (nn - 1) * d0[i] ** nn / (d0[i] + floor) ** 2
        else:
            F2[i] = nn * (nn - 1) * d0[i] ** (nn - 2)
    out = np.empty_like(Y)
    eta = np.empty((M, beads - 1))
    du = np.empty((M, beads))
    dv = np.empty((M, beads))
    for j in range(M):
        a, b = monos[j, 0], monos[j, 1]
        for i in range(beads):
            out[2 * j, i] = Y[2 * j + 1, i]
        for i in range(beads - 1):
            eta[j, i] = Y[2 * j, i] - Y[2 * j, i + 1]
        for i in range(beads):
            out[2 * j + 1, i] = mask[i] * (_power(x0[i], a) * _power(v0[i], b))
            du[j, i] = a * _power(x0[i], a - 1) * _power(v0[i], b) if a else 0.0
            dv[j, i] = b * _power(x0[i], a) * _power(v0[i], b - 1) if b else 0.0
        for i in range(beads - 1):
            f = F1[i] * eta[j, i]
            out[2 * j + 1, i + 1] += f
            out[2 * j + 1, i] -= f
    for q in range(P):
        j, l = pairs[q, 0], pairs[q, 1]
        z = 2 * (M + q)
        for i in range(beads):
            out[z, i] = Y[z + 1, i]
        weight = 0.5 if j == l else 1.0
        for i in range(beads):
            lin = du[j, i] * Y[2 * l, i] + dv[j, i] * Y[2 * l + 1, i]
            if j != l:
                lin = lin + du[l, i] * Y[2 * j, i] + dv[l, i] * Y[2 * j + 1, i]
            out[z + 1, i] = mask[i] * lin
        for i in range(beads - 1):
            f = F1[i] * (Y[z, i] - Y[z, i + 1]) + weight * F2[i] * (eta[j, i] * eta[l, i])
            out[z + 1, i + 1] += f
            out[z + 1, i] -= f
    return out.ravel()
