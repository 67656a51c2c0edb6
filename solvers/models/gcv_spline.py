"""scipy's GCV smoothing spline (``make_smoothing_spline`` with ``lam=None``), its GCV search made fast.

scipy computes the GCV criterion (Wahba 1990; trace by Hutchinson & de Hoog 1985) with Python loops
over numpy scalars, ~3 ms per evaluation and ~30 evaluations per fit: most of a cold relaxed build.
``gcv_smoothing_spline`` runs the same arithmetic, operation for operation and in the same order
(loops over Python floats or vectorised across independent elements), through the same bounded
minimiser, then lets scipy fit the spline at the lambda found: the result equals
``make_smoothing_spline(x, y, w=w)`` bit for bit (tests/models/test_gcv_spline.py). Written against
scipy 1.17's algorithm; callers key cached fits by the scipy version.
"""

from __future__ import annotations

import numpy as np


def gcv_smoothing_spline(x: np.ndarray, y: np.ndarray, w: np.ndarray):
    """make_smoothing_spline(x, y, w=w) for 1-D y: the GCV lambda (``gcv_lambda``), then scipy's
    solve in the natural-spline basis and its change to the B-spline basis."""
    from scipy.interpolate import BSpline
    from scipy.linalg import solve_banded

    x, y, w = (np.ascontiguousarray(a, dtype=float) for a in (x, y, w))
    if x.ndim != 1 or y.shape != x.shape or w.shape != x.shape or x.size <= 4:
        raise ValueError(f"x, y, w must be 1-D of one length >= 5, got shapes {x.shape}, {y.shape}, {w.shape}")
    if np.any(x[1:] - x[:-1] <= 0) or np.any(w <= 0):
        raise ValueError("x must be ascending and w > 0")
    X, wE = _bands(x, w)
    c = solve_banded((2, 2), X + gcv_lambda(x, y, w, X, wE) * wE, y)
    t = np.r_[[x[0]] * 3, x, [x[-1]] * 3]
    c_ = np.r_[c[0:1] * (t[5] + t[4] - 2 * t[3]) + c[1:2], c[0:1] * (t[5] - t[3]) + c[1:2], c[1:-1],
               c[-1:-2:-1] * (t[-4] - t[-6]) + c[-2:-3:-1], c[-1:-2:-1] * (2 * t[-4] - t[-5] - t[-6]) + c[-2:-3:-1]]
    return BSpline.construct_fast(t, c_, 3)


def gcv_lambda(x: np.ndarray, y: np.ndarray, w: np.ndarray, X: np.ndarray, wE: np.ndarray) -> float:
    """The GCV-optimal lambda of scipy's make_smoothing_spline (its _compute_optimal_gcv_parameter);
    X, wE: ``_bands(x, w)``."""
    from scipy.linalg import LinAlgError
    from scipy.optimize import minimize_scalar

    n = x.size
    XtWX, XtE = _xt_w_y(X, w, X), _xt_w_y(X, w, wE)

    def gcv(lam: float) -> float:
        try:
            return _gcv(lam, X, XtWX, wE, XtE, y)
        except LinAlgError:
            raise ValueError("Seems like the problem is ill-posed") from None

    est = minimize_scalar(gcv, bounds=(0, n), method="Bounded")
    if not est.success:
        raise ValueError(f"Unable to find minimum of the GCV function: {est.message}")
    return est.x


def _coeff_of_divided_diff(x: np.ndarray) -> np.ndarray:
    n = x.shape[0]
    res = np.zeros(n)
    for i in range(n):
        pp = 1.0
        for k in range(n):
            if k != i:
                pp *= x[i] - x[k]
        res[i] = 1.0 / pp
    return res


def _bands(x: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(X, W^-1 E): the design and penalty matrices in the natural-spline basis, banded, as scipy builds them."""
    from scipy.interpolate import BSpline

    n = x.shape[0]
    t = np.r_[[x[0]] * 3, x, [x[-1]] * 3]
    Xb = BSpline.design_matrix(x, t, 3)
    X = np.zeros((5, n))
    for i in range(1, 4):
        X[i, 2:-2] = Xb[i: i - 4, 3:-3][np.diag_indices(n - 4)]
    X[1, 1] = Xb[0, 0]
    X[2, :2] = ((x[2] + x[1] - 2 * x[0]) * Xb[0, 0], Xb[1, 1] + Xb[1, 2])
    X[3, :2] = ((x[2] - x[0]) * Xb[1, 1], Xb[2, 2])
    X[1, -2:] = (Xb[-3, -3], (x[-1] - x[-3]) * Xb[-2, -2])
    X[2, -2:] = (Xb[-2, -3] + Xb[-2, -2], (2 * x[-1] - x[-2] - x[-3]) * Xb[-1, -1])
    X[3, -2] = Xb[-1, -1]
    wE = np.zeros((5, n))
    wE[2:, 0] = _coeff_of_divided_diff(x[:3]) / w[:3]
    wE[1:, 1] = _coeff_of_divided_diff(x[:4]) / w[:4]
    if n > 4:  # columns 2..n-3 at once: window j-2..j+2, the products in scipy's order
        xs = np.lib.stride_tricks.sliding_window_view(x, 5)
        ws = np.lib.stride_tricks.sliding_window_view(w, 5)
        coeff = np.empty_like(xs)
        for i in range(5):
            pp = np.ones(xs.shape[0])
            for k in range(5):
                if k != i:
                    pp *= xs[:, i] - xs[:, k]
            coeff[:, i] = 1.0 / pp
        wE[:, 2:n - 2] = ((x[4:] - x[:-4])[:, None] * coeff / ws).T
    wE[:-1, -2] = -_coeff_of_divided_diff(x[-4:]) / w[-4:]
    wE[:-2, -1] = _coeff_of_divided_diff(x[-3:]) / w[-3:]
    wE *= 6
    return X, wE


def _xt_w_y(X: np.ndarray, w: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """The 4 unique bands of the symmetric X^T W Y (X, Y 5-banded), summed in scipy's order."""
    W_Y = np.copy(Y)
    W_Y[2] *= w
    for i in range(2):
        W_Y[i, 2 - i:] *= w[:-2 + i]
        W_Y[3 + i, :-1 - i] *= w[1 + i:]
    n = X.shape[1]
    res = np.zeros((4, n))
    for j in range(min(n, 4)):
        cols = n - j  # i = 0..n-j-1; term m = X[j + m, i] * W_Y[m, i + j], added in order of m
        acc = np.zeros(cols)
        for m in range(5 - j):
            acc = acc + X[j + m, :cols] * W_Y[m, j:j + cols]
        res[-j - 1, j:] = acc
    return res


def _gcv(lam: float, X: np.ndarray, XtWX: np.ndarray, wE: np.ndarray, XtE: np.ndarray, y: np.ndarray) -> float:
    """GCV(lambda) = (|lambda W^-1 E c|^2 / n) / (1 - tr A / n)^2, as scipy's _gcv computes it."""
    from scipy.linalg import solve_banded

    n = X.shape[1]
    c = solve_banded((2, 2), X + lam * wE, y)
    tmp = wE * c
    res = np.zeros(n)
    for j in range(5):  # res[i] += tmp[j, i + 2 - j] for j ascending, over the i where both indices exist
        lo, hi = max(0, j - 2), min(n - 1, j + n - 3)
        res[lo:hi + 1] += tmp[j, lo + 2 - j:hi + 3 - j]
    numer = np.linalg.norm(lam * res) ** 2 / n
    tr = _b_inv(XtWX + lam * XtE) * XtWX
    tr[:-1] *= 2
    denom = (1 - sum(sum(tr)) / n) ** 2
    return numer / denom


def _b_inv(A: np.ndarray) -> np.ndarray:
    """3 central bands of A^-1 for banded symmetric positive definite A (Hutchinson & de Hoog), scipy's
    recursion over Python floats; the first row zero."""
    from scipy.linalg import cholesky_banded

    U = cholesky_banded(A)
    for i in range(2, 5):
        U[-i, i - 1:] /= U[-1, :-i + 1]
    D = (1.0 / (U[-1]) ** 2).tolist()
    U[-1] /= U[-1]
    n = U.shape[1]
    u0, u1, u2, _ = (row.tolist() for row in U)
    B = [[0.0] * n for _ in range(4)]
    b0, b1, b2, b3 = B
    for i in range(n - 1, max(n - 4, -1), -1):  # the last rows: fewer than 3 bands below
        rng = n - i - 1
        for j in range(rng, -1, -1):
            s = 0.0
            if j == 0:
                for k in range(1, rng + 1):
                    s -= U[-k - 1, i + k] * B[-k - 1][i + k]
                s += D[i]
                B[-1][i] = float(s)
            else:
                for k in range(1, rng + 1):
                    diag = abs(k - j)
                    s -= U[-k - 1, i + k] * B[-diag - 1][i + min(k, j) + diag]
                B[-j - 1][i + j] = float(s)
    for i in range(n - 4, -1, -1):  # the same recursion with its three terms written out (j = 3, 2, 1, 0)
        a, b, c = u2[i + 1], u1[i + 2], u0[i + 3]
        b0[i + 3] = 0.0 - a * b1[i + 3] - b * b2[i + 3] - c * b3[i + 3]
        b1[i + 2] = 0.0 - a * b2[i + 2] - b * b3[i + 2] - c * b2[i + 3]
        b2[i + 1] = 0.0 - a * b3[i + 1] - b * b2[i + 2] - c * b1[i + 3]
        b3[i] = 0.0 - a * b2[i + 1] - b * b1[i + 2] - c * b0[i + 3] + D[i]
    out = np.array(B)
    out[0] = 0.0
    return out
