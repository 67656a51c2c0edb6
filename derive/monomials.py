"""R(u, v) as monomials u^a v^b, for the compiled DNS of paper Eq. 1 (solvers/chain/compiled.py).

    eps_i R_i(u, v) = sum_m c_m[i] u^(a_m) v^(b_m)

The generated force module (derive/codegen.py) carries the exponents (``MONOMIALS``) and the
per-bead coefficients (``monomial_coefficients``), so the compiled kernel takes R as data: a new
polynomial R costs no compilation. A non-polynomial R (sin(u), sign(v), ...) has no table.
"""

from __future__ import annotations

import sympy

from pulsemap.symbolic.expression import is_polynomial_in_state, symbol


def polynomial_terms(R: sympy.Expr) -> list[tuple[int, int, sympy.Expr]] | None:
    """[(a, b, c_ab)] with R = sum c_ab u^a v^b (c_ab free of u, v; nonzero), or None when R is not a
    polynomial in u and v. Coefficients may depend on the parameters and the bead index i."""
    if not is_polynomial_in_state(R):
        return None
    u, v = symbol("u"), symbol("v")
    terms = sympy.Poly(sympy.expand(R), u, v).terms()
    return [(int(a), int(b), sympy.factor_terms(c)) for (a, b), c in terms if c != 0]
