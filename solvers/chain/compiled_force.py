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

# numba cache stamp: b6266238713c7034
from __future__ import annotations

import numpy as np
from pulsemap.solvers.chain.jit import njit, types
from numba.extending import overload


def add_onsite(acc, x, v, b0, exps, coef):  # pragma: no cover - numba replaces it (overload below)
    """acc + F_{b0}(x, v) (b0: the 0-based bead)."""
    raise NotImplementedError("compiled code only")


def onsite_slopes(x, v, b0, exps, coef):  # pragma: no cover - numba replaces it (overload below)
    """(dF/dx, dF/dv) of bead b0 at (x, v)."""
    raise NotImplementedError("compiled code only")


def tail_start(exps, coef):  # pragma: no cover - numba replaces it (overload below)
    """The first 0-based bead of the uniform tail: it and every bead after it read the force's last column."""
    raise NotImplementedError("compiled code only")


def tail_force(exps, coef):  # pragma: no cover - numba replaces it (overload below)
    """The tail's force as add_tail reads it: the dense form's eight coefficients (held in registers across a
    loop over beads), else 0.0 (add_tail is add_onsite)."""
    raise NotImplementedError("compiled code only")


def add_tail(acc, x, v, b0, tail, exps, coef):  # pragma: no cover - numba replaces it (overload below)
    """add_onsite of a bead b0 >= tail_start, from tail_force's ``tail`` (the same arithmetic)."""
    raise NotImplementedError("compiled code only")


@njit(cache=True)
def _table_onsite(acc, x, v, b0, exps, coef):
    """add_onsite of the general monomial table (a call, not inlined: numba inlines no loop cleanly)."""
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
        return lambda acc, x, v, b0, exps, coef: _table_onsite(acc, x, v, b0, exps, coef)

    def function(acc, x, v, b0, exps, coef):
        return acc + exps[0](x, v, b0 + 1.0, coef[min(b0, coef.shape[0] - 1)].ctypes)

    return function


@overload(tail_start, inline="always")
def _tail_start(exps, coef):
    if isinstance(coef, types.Array) and coef.ndim == 3:
        return lambda exps, coef: coef.shape[2] - 1
    if isinstance(exps, types.Array):
        return lambda exps, coef: coef.shape[1] - 1
    return lambda exps, coef: coef.shape[0] - 1


@overload(tail_force, inline="always")
def _tail_force(exps, coef):
    if isinstance(coef, types.Array) and coef.ndim == 3:
        def dense(exps, coef):
            c = coef.shape[2] - 1
            return (coef[0, 0, c], coef[0, 1, c], coef[0, 2, c], coef[0, 3, c],
                    coef[1, 0, c], coef[1, 1, c], coef[1, 2, c], coef[1, 3, c])

        return dense
    return lambda exps, coef: 0.0


@overload(add_tail, inline="always")
def _add_tail(acc, x, v, b0, tail, exps, coef):
    if isinstance(coef, types.Array) and coef.ndim == 3:
        def dense(acc, x, v, b0, tail, exps, coef):  # add_onsite's dense form, term for term
            p0 = ((tail[3] * x + tail[2]) * x + tail[1]) * x + tail[0]
            p1 = ((tail[7] * x + tail[6]) * x + tail[5]) * x + tail[4]
            return acc + (p0 + v * p1)

        return dense
    return lambda acc, x, v, b0, tail, exps, coef: add_onsite(acc, x, v, b0, exps, coef)


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


# --- the contact law's term eps_c P_k(d, w) and the bead masses (chain/contact_force.py's kernel_terms): one
# array ``ct`` (1 + M, 2 + L): row 0 holds the inverse masses in columns 2.., row 1 + m the exponents a_m, b_m in
# columns 0, 1 and the per-contact coefficients in columns 2.. (column 2 + min(k0, L - 1)); or, for the Hertz chain
# of unit masses, a 1-d ``ct`` (the bare form; None once lean() has dropped it): numba then compiles each helper to
# exactly the arithmetic of the bare chain (same numbers). One array, not three: every right-hand-side call passes it.


def lean(exps, coef, ct):  # pragma: no cover - numba replaces it (overload below)
    """(exps, coef, ct) with what the form never reads as None: exps in the dense form, ct in the bare form. Each
    kernel's run hands these on, so the bare chain's calls do not copy an array no helper reads (a numba array
    argument is 5 + 2 ndim machine words in every call of the right-hand side)."""
    raise NotImplementedError("compiled code only")


def contact_force(d, wd, k0, n, ct):  # pragma: no cover - numba replaces it (overload below)
    """F(d, w) = d^n + eps_c P_k0(d, w) of contact k0 (0-based) at overlap d > 0 and its rate wd."""
    raise NotImplementedError("compiled code only")


def contact_slopes(d, wd, k0, n, ct):  # pragma: no cover - numba replaces it (overload below)
    """(dF/dd, dF/dw) of contact k0 at overlap d > 0 and rate wd."""
    raise NotImplementedError("compiled code only")


def push(d, wd, k0, n, ct):  # pragma: no cover - numba replaces it (overload below)
    """contact_force of contact k0 when it is closed (d > 0), else 0: what the bead behind it pushes with."""
    raise NotImplementedError("compiled code only")


def inverse_mass(b0, ct):  # pragma: no cover - numba replaces it (overload below)
    """1 / m of bead b0 (0-based)."""
    raise NotImplementedError("compiled code only")


def kinetic(v, b0, ct):  # pragma: no cover - numba replaces it (overload below)
    """m v^2 / 2 of bead b0 with velocity v."""
    raise NotImplementedError("compiled code only")


def has_terms(ct):  # pragma: no cover - numba replaces it (overload below)
    """True when the chain has a contact term or masses (the table form), a compile-time constant."""
    raise NotImplementedError("compiled code only")


@njit(cache=True, inline="always")
def _pow(d, a):
    """d^a for d > 0 (a = 0, 1/2, 1 without pow)."""
    if a == 0.0:
        return 1.0
    if a == 0.5:
        return np.sqrt(d)
    if a == 1.0:
        return d
    return d**a


@njit(cache=True, inline="always")
def pos_pow(d: float, n: float) -> float:
    """d^n for d > 0 (n = 1.5 and n = 0.5, the Hertz force and its slope's power, by a square root)."""
    if n == 1.5:
        return d * np.sqrt(d)
    if n == 0.5:
        return np.sqrt(d)
    return d**n


def _bare(ct) -> bool:
    return ct is types.none or (isinstance(ct, types.Array) and ct.ndim == 1)


@overload(lean)
def _lean(exps, coef, ct):
    dense = isinstance(coef, types.Array) and coef.ndim == 3
    if dense and _bare(ct):
        return lambda exps, coef, ct: (None, coef, None)
    if dense:
        return lambda exps, coef, ct: (None, coef, ct)
    if _bare(ct):
        return lambda exps, coef, ct: (exps, coef, None)
    return lambda exps, coef, ct: (exps, coef, ct)


@njit(cache=True)
def _table_force(d, wd, k0, n, ct):
    """contact_force of the table form (a call, not inlined: numba inlines no loop cleanly)."""
    col = 2 + min(k0, ct.shape[1] - 3)
    f = pos_pow(d, n)
    for m in range(1, ct.shape[0]):
        c = ct[m, col]
        if c != 0.0:
            p = c * _pow(d, ct[m, 0])
            for _ in range(int(ct[m, 1])):
                p *= wd
            f += p
    return f


@njit(cache=True)
def _table_slopes(d, wd, k0, n, ct):
    """contact_slopes of the table form."""
    col = 2 + min(k0, ct.shape[1] - 3)
    sd = n * pos_pow(d, n - 1.0)
    sw = 0.0
    for m in range(1, ct.shape[0]):
        c = ct[m, col]
        a, b = ct[m, 0], int(ct[m, 1])
        if c != 0.0:
            wb1 = 1.0  # w^(b-1)
            for _ in range(b - 1):
                wb1 *= wd
            wb = wb1 * wd if b > 0 else 1.0
            if b > 0:
                sw += c * b * _pow(d, a) * wb1
            if a != 0.0:
                sd += c * a * d ** (a - 1.0) * wb
    return sd, sw


@overload(contact_force)
def _contact_force(d, wd, k0, n, ct):
    if _bare(ct):
        return lambda d, wd, k0, n, ct: pos_pow(d, n)
    return lambda d, wd, k0, n, ct: _table_force(d, wd, k0, n, ct)


@overload(contact_slopes)
def _contact_slopes(d, wd, k0, n, ct):
    if _bare(ct):
        return lambda d, wd, k0, n, ct: (n * pos_pow(d, n - 1.0), 0.0)
    return lambda d, wd, k0, n, ct: _table_slopes(d, wd, k0, n, ct)


@overload(push)
def _push(d, wd, k0, n, ct):
    if _bare(ct):
        def bare(d, wd, k0, n, ct):
            f = 0.0
            if d > 0.0:
                f = pos_pow(d, n)
            return f

        return bare
    return lambda d, wd, k0, n, ct: _table_force(d, wd, k0, n, ct) if d > 0.0 else 0.0


@overload(inverse_mass, inline="always")
def _inverse_mass(b0, ct):
    if _bare(ct):
        return lambda b0, ct: 1.0
    return lambda b0, ct: ct[0, 2 + min(b0, ct.shape[1] - 3)]


@overload(kinetic, inline="always")
def _kinetic(v, b0, ct):
    if _bare(ct):
        return lambda v, b0, ct: 0.5 * v * v
    return lambda v, b0, ct: 0.5 * v * v / ct[0, 2 + min(b0, ct.shape[1] - 3)]


@overload(has_terms, inline="always")
def _has_terms(ct):
    if _bare(ct):
        return lambda ct: False
    return lambda ct: True
