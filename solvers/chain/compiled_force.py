"""The on-site force F_i(x_i, v_i) of paper Eq. 1 inside the compiled kernels, whatever form R has.

    x_i'' = (x_{i-1} - x_i)_+^n - (x_i - x_{i+1})_+^n + F_i(x_i, x_i')             (paper Eq. 1)

The kernels take the force as two arguments ``(exps, coef)``: a monomial table (int64 exponents
(M, 2) and per-bead coefficients (M, L); F = sum_m c_m[i] x^a_m v^b_m, force_table.MonomialTable), its
dense form (coef (2, 4, L): F = P_0(x) + v P_1(x), P_b(x) = sum_a coef[b, a, i] x^a, by Horner; the
table's kernel_args when a <= 3 and b <= 1) or a generated numba force (a tuple of three C callables
force, dF/dx, dF/dv and their per-bead arguments (L, 1 + P): [eps_i, parameters at bead i],
force_table.JitForce). numba specialises a kernel once per form, so one compiled kernel serves every
polynomial R (two: the dense form and the general table) and one every other R. All read
column/row min(b0, L - 1) for the 0-based bead b0 (a uniform tail is stored once).
"""

# numba cache stamp: fa9ca95239125c63
from __future__ import annotations

from pulsemap.solvers.chain.jit import types
from numba.extending import overload


def add_onsite(acc, x, v, b0, exps, coef):  # pragma: no cover - numba replaces it (overload below)
    """acc + F_{b0}(x, v) (b0: the 0-based bead)."""
    raise NotImplementedError("compiled code only")


def onsite_slopes(x, v, b0, exps, coef):  # pragma: no cover - numba replaces it (overload below)
    """(dF/dx, dF/dv) of bead b0 at (x, v)."""
    raise NotImplementedError("compiled code only")


@overload(add_onsite, inline="always")
def _add_onsite(acc, x, v, b0, exps, coef):
    if isinstance(coef, types.Array) and coef.ndim == 3:
        def dense(acc, x, v, b0, exps, coef):
            col = min(b0, coef.shape[2] - 1)
            p0 = ((coef[0, 3, col] * x + coef[0, 2, col]) * x + coef[0, 1, col]) * x + coef[0, 0, col]
            p1 = ((coef[1, 3, col] * x + coef[1, 2, col]) * x + coef[1, 1, col]) * x + coef[1, 0, col]
            return acc + (p0 + v * p1)

        return dense
    if isinstance(exps, types.Array):
        def table(acc, x, v, b0, exps, coef):
            col = b0
            if col >= coef.shape[1]:
                col = coef.shape[1] - 1
            for m in range(exps.shape[0]):
                c = coef[m, col]
                if c != 0.0:
                    p = c
                    for _ in range(exps[m, 0]):
                        p *= x
                    for _ in range(exps[m, 1]):
                        p *= v
                    acc += p
            return acc

        return table

    def function(acc, x, v, b0, exps, coef):
        return acc + exps[0](x, v, b0 + 1.0, coef[min(b0, coef.shape[0] - 1)].ctypes)

    return function


@overload(onsite_slopes, inline="always")
def _onsite_slopes(x, v, b0, exps, coef):
    if isinstance(coef, types.Array) and coef.ndim == 3:
        def dense(x, v, b0, exps, coef):
            col = min(b0, coef.shape[2] - 1)
            dp0 = (3.0 * coef[0, 3, col] * x + 2.0 * coef[0, 2, col]) * x + coef[0, 1, col]
            dp1 = (3.0 * coef[1, 3, col] * x + 2.0 * coef[1, 2, col]) * x + coef[1, 1, col]
            p1 = ((coef[1, 3, col] * x + coef[1, 2, col]) * x + coef[1, 1, col]) * x + coef[1, 0, col]
            return dp0 + v * dp1, p1

        return dense
    if isinstance(exps, types.Array):
        def table(x, v, b0, exps, coef):
            col = min(b0, coef.shape[1] - 1)
            gx, gv = 0.0, 0.0
            for m in range(exps.shape[0]):
                c = coef[m, col]
                a, b = exps[m, 0], exps[m, 1]
                if c != 0.0:
                    if a > 0:
                        gx += c * a * x ** (a - 1) * v**b
                    if b > 0:
                        gv += c * b * x**a * v ** (b - 1)
            return gx, gv

        return table

    def function(x, v, b0, exps, coef):
        args = coef[min(b0, coef.shape[0] - 1)].ctypes
        return exps[1](x, v, b0 + 1.0, args), exps[2](x, v, b0 + 1.0, args)

    return function
