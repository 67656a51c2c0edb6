"""The on-site force of paper Eq. 1 as the compiled kernels take it (solvers/chain/compiled_force.py).

    x_i'' = (x_{i-1} - x_i)_+^n - (x_i - x_{i+1})_+^n + eps_i R_i(x_i, x_i')       (paper Eq. 1)

A polynomial R enters as a monomial table (the generated force module's MONOMIALS and
monomial_coefficients, derive/monomials.py), so a new polynomial R costs no compilation; any other
R as a generated numba force (JitForce: derive/codegen_jitforce.py, in the cache; sign, Heaviside
and abs as the scipy engine's ramp), compiled once per R. A table whose monomials are u^a v^b with
a <= 3, b <= 1 (every R of the paper: damping, linear and cubic foundations, Van der Pol) reaches
the kernels in its dense form P_0(u) + v P_1(u), two cubics by Horner (MonomialTable.kernel_args):
the general loop over monomials is the kernels' most expensive part (docs/dns.rst).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from pulsemap.solvers.chain.errors import DNSInputError

Array = np.ndarray
DENSE_DEGREES = (4, 2)  # the dense form's powers: u^0..u^3 times v^0, v^1 (compiled_force.py)


@dataclass(frozen=True)
class MonomialTable:
    """eps_i R_i(u, v) = sum_m coefficients[m, min(i-1, L-1)] u^a_m v^b_m (i 1-based bead), Eq. 1.

    ``exponents``: (M, 2) int64 (a_m, b_m); ``coefficients``: (M, L) float64, eps and the
    perturbed range folded in (``table_from_module`` builds both from the generated force module).
    """

    exponents: Array
    coefficients: Array

    @classmethod
    def of(cls, exponents, coefficients) -> "MonomialTable":
        e = np.ascontiguousarray(np.asarray(exponents, dtype=np.int64).reshape(-1, 2))
        c = np.ascontiguousarray(np.asarray(coefficients, dtype=np.float64))
        if c.ndim == 1:
            c = c.reshape(len(e), -1)
        if c.shape[0] != e.shape[0] or c.shape[1] < 1 or np.any(e < 0):
            raise DNSInputError(f"monomial table: exponents {e.shape} >= 0 and coefficients (M, L >= 1), got {c.shape}")
        if not np.all(np.isfinite(c)):
            raise DNSInputError("monomial table: coefficients must be finite")
        return cls(e, c)

    @classmethod
    def zero(cls) -> "MonomialTable":
        return cls(np.zeros((0, 2), dtype=np.int64), np.zeros((0, 1)))

    @property
    def constant_term(self) -> bool:
        """True when some bead has a nonzero u^0 v^0 term (R(0, 0) != 0: not a chain at rest)."""
        rows = np.flatnonzero((self.exponents[:, 0] == 0) & (self.exponents[:, 1] == 0))
        return bool(rows.size and np.any(self.coefficients[rows] != 0.0))

    @cached_property
    def kernel_args(self) -> tuple:
        """The kernels' (exps, coef) (solvers/chain/compiled_force.py): the dense form (coef of shape
        (2, 4, L): coef[b, a, col] multiplies u^a v^b) when every monomial has a <= 3 and b <= 1,
        else the table itself (coef (M, L)); R = 0 stays an empty table (nothing to evaluate)."""
        e, c = self.exponents, self.coefficients
        na, nb = DENSE_DEGREES
        if e.shape[0] == 0 or np.any(e[:, 0] >= na) or np.any(e[:, 1] >= nb):
            return e, c
        dense = np.zeros((nb, na, c.shape[1]))
        for m, (a, b) in enumerate(e):
            dense[b, a] += c[m]
        return e, dense

    @property
    def conservative(self) -> bool:
        """R = 0: the energy is conserved (its drift is reported)."""
        return self.exponents.shape[0] == 0

    @property
    def stiffness_hint(self) -> float:
        """The rate OnSiteForce.stiffness_hint gives (solvers/studies/points.py): max over beads of
        |dF/dv| and sqrt|dF/dx| at rest, i.e. of the u^0 v^1 and u^1 v^0 coefficients."""
        def largest(a: int, b: int) -> float:
            rows = (self.exponents[:, 0] == a) & (self.exponents[:, 1] == b)
            return float(np.abs(self.coefficients[rows].sum(axis=0)).max(initial=0.0))

        return max(largest(0, 1), float(np.sqrt(largest(1, 0))))

    @property
    def describe(self) -> str:
        """How R reached the kernels (the two forms round differently: results say which ran)."""
        dense = self.kernel_args[1].ndim == 3
        return "monomial table (dense form: cubics P_0(u) + v P_1(u))" if dense else "monomial table"


def monomial_text(a: int, b: int) -> str:
    """R's monomial u^a v^b as a scene writes it, ``u^a*v^b`` (a factor with exponent 0 left out)."""
    return "*".join([f"u^{a}"] * (a > 0) + [f"v^{b}"] * (b > 0))


@dataclass(frozen=True)
class JitForce:
    """eps_i R_i as a generated numba force (derive/codegen_jitforce.py, a non-polynomial R), Eq. 1:
    ``functions`` its C callables (force, dF/dx, dF/dv), ``arguments`` (L, 1 + P) whose row
    min(i-1, L-1) is [eps_i, the parameters at bead i] (``jit_force`` builds both); ``ramp`` the
    half-width of the ramp a non-smooth R's sign and Heaviside are integrated as (0.0: none)."""

    functions: tuple
    arguments: Array
    ramp: float = 0.0

    @property
    def kernel_args(self) -> tuple:
        return self.functions, self.arguments

    conservative = False

    @property
    def describe(self) -> str:
        """How R reached the kernels (a non-smooth R: as which ramp)."""
        if self.ramp:
            return f"R as a generated numba function (non-smooth: sign as a ramp of half-width {self.ramp:g})"
        return "R as a generated numba function (not a polynomial)"


def _needed(rows: Array) -> int:
    """How many leading rows of ``rows`` (beads first) to keep: past the last that differs from the
    final row every bead is alike (uniform R: O(1) memory)."""
    differs = np.flatnonzero(np.any(rows != rows[-1:], axis=tuple(range(1, rows.ndim))))
    return 1 if differs.size == 0 else int(differs[-1]) + 2


def jit_force(module, index: Array, eps: Array, params: tuple) -> JitForce:
    """The generated numba force module's functions with their per-bead arguments ([eps_i, params]
    in module.PARAMS order; a parameter is a float or an array over beads)."""
    rows = np.column_stack([np.broadcast_to(np.asarray(a, float), index.shape) for a in (eps, *params)])
    return JitForce((module.force, module.force_dx, module.force_dv),
                    np.ascontiguousarray(rows[: _needed(rows)], dtype=np.float64), float(getattr(module, "DELTA", 0.0)))


def table_from_module(module, index: Array, eps: Array, params: tuple) -> MonomialTable | None:
    """The generated force module's eps_i R_i as a table (None: R is not polynomial, or the module
    predates tables); columns past the last bead-dependent one are dropped (uniform R: O(1) memory)."""
    exponents = getattr(module, "MONOMIALS", None)
    if exponents is None:
        return None
    if not exponents:
        return MonomialTable.zero()
    with np.errstate(all="ignore"):
        coef = np.array([np.broadcast_to(np.asarray(c, float), index.shape)
                         for c in module.monomial_coefficients(index, eps, *params)])
    return MonomialTable.of(exponents, coef[:, : _needed(coef.T)].copy())


def force_data(force) -> tuple[MonomialTable | JitForce | None, str]:
    """The on-site force as the kernels take it (a monomial table, else the generated numba force the
    force's ``jit`` builds) and "", or None and why the scipy engine must run instead."""
    if force is None:
        return MonomialTable.zero(), ""
    table = force.monomials
    if table is not None:
        return (None, "R(0, 0) != 0: the monomial table has a constant term") if table.constant_term else (table, "")
    if force.jit is None:
        return None, "the on-site force has no monomial table and no generated numba form (a Python callable)"
    data = force.jit()
    return (None, data) if isinstance(data, str) else (data, "")
