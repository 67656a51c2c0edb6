"""Scaling symmetry of the Hertz chain with an on-site monomial (paper Eq. 1).

Eq. 1 is invariant under x -> lambda x, t -> lambda^(-s) t, s = (n - 1)/2, except for the on-site
term: eps c u^a v^b picks up lambda^(a + (1+s) b) against lambda^n for the contact forces. So a
pulse of amplitude A under eps c u^a v^b behaves exactly like a pulse of amplitude 1 under the
coefficient x = eps c A^e,

    e = a + b (n + 1)/2 - n          (n = 3/2: e = a + 5b/4 - 3/2),

and every amplitude ratio (P_{k+1}/P_k) is a function of x alone.

Importing this module loads no sympy (only monomial_exponents does, when called): the numeric
side (solvers/models) takes scaling_exponent from here.
"""

from __future__ import annotations

import typing

if typing.TYPE_CHECKING:  # pragma: no cover
    import sympy


def monomial_exponents(R: "sympy.Expr") -> tuple[int, int] | None:
    """(a, b) when R = c u^a v^b with c free of u and v (c may hold parameters and i); else None."""
    import sympy

    from .expression import symbol

    u, v = symbol("u"), symbol("v")
    expr = sympy.expand(R)
    if expr == 0:
        return None
    try:
        poly = sympy.Poly(expr, u, v)
    except sympy.PolynomialError:
        return None
    if len(poly.terms()) != 1:
        return None
    (a, b), coeff = poly.terms()[0]
    if coeff.free_symbols & {u, v}:
        return None
    return int(a), int(b)


def scaling_exponent(a: int, b: int, n: float) -> float:
    """e of x = eps c A^e for the monomial u^a v^b at contact exponent n (module docstring)."""
    return float(a) + float(b) * (float(n) + 1.0) / 2.0 - float(n)
