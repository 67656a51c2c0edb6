"""R(u, v) as a monomial table for the compiled DNS of paper Eq. 1 (solvers/chain/compiled.py).

    eps_i R_i(u, v) = sum_m c_m[i] u^(a_m) v^(b_m),   c_m[i] = 0 for beads i < first_perturbed

The table is data, not code: a new polynomial R costs no compilation. The coefficients are
evaluated per bead when they depend on the bead index i or on site-dependent parameters;
otherwise one column per unperturbed bead plus one for every perturbed bead (the kernel reads
column min(i, columns - 1)), so a chain of 10^6 beads costs no O(N) memory.
"""

from __future__ import annotations

import numpy as np
import sympy

from pulsemap.derive.expression import is_polynomial_in_state, symbol
from pulsemap.derive.perturbation import Perturbation, _evaluate


class NotPolynomialError(ValueError):
    """R is not a polynomial in u and v: the compiled kernel cannot take it as a table."""


def monomial_table(pert: Perturbation, beads: int, first_perturbed: int) -> tuple[np.ndarray, np.ndarray]:
    """(exponents (M, 2) int64 of u^a v^b, coefficients (M, L) float64) of eps_i R_i, Eq. 1.

    Column j holds bead j+1's coefficients; beads past column L-1 use column L-1. Raises
    NotPolynomialError for a non-polynomial R (e.g. sin(u), sign(v)).
    """
    u, v = symbol("u"), symbol("v")
    if not is_polynomial_in_state(pert.R):
        raise NotPolynomialError(f"R = {pert.text} is not a polynomial in u, v")
    terms = [(a, b, c) for (a, b), c in sympy.Poly(sympy.expand(pert.R), u, v).terms() if c != 0]
    beads, fp = int(beads), int(first_perturbed)
    uniform = pert.is_uniform
    columns = min(beads, fp) if uniform else beads
    mask = (np.arange(1, columns + 1) >= fp) * float(pert.eps)
    exps = np.zeros((len(terms), 2), dtype=np.int64)
    coef = np.zeros((len(terms), max(columns, 1)))
    env = {} if uniform else {symbol(name): pert.bead_values(name, beads) for name in pert.used_parameters}
    scalars = pert.scalar_values()
    for m, (a, b, c) in enumerate(terms):
        exps[m] = a, b
        c = c.xreplace(scalars) if uniform else c
        values = float(c) if uniform else _evaluate(c, env, beads, f"coefficient of u^{a} v^{b}")
        coef[m] = mask * values
    return exps, coef
