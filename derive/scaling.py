"""Scaling symmetry of the Hertz chain with an on-site monomial (paper Eq. 1).

Eq. 1 is invariant under x -> lambda x, t -> lambda^(-s) t, s = (n - 1)/2, except for the on-site
term: eps c u^a v^b picks up lambda^(a + (1+s) b) against lambda^n for the contact forces. So a
pulse of amplitude A under eps c u^a v^b behaves exactly like a pulse of amplitude 1 under the
coefficient x = eps c A^e,

    e = a + b (n + 1)/2 - n          (n = 3/2: e = a + 5b/4 - 3/2),

and every amplitude ratio (P_{k+1}/P_k) is a function of x alone.

Importing this module loads no sympy (only monomial_exponents and homogeneous_form do, when called): the numeric
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


def homogeneous_form(R: "sympy.Expr", n: float) -> tuple[str, float] | None:
    """(text of h, e) when R = c h(u, v) with c free of u and v and h homogeneous under the symmetry of Eq. 1,
    h(l u, l^(1+s) v) = l^d h(u, v) for l > 0 (sign(v): d = 0; v*abs(v): d = 2 (1 + s)), scaled to h(1, 1) = 1;
    e = d - n, as a monomial's. None when R is not of that form or h(1, 1) = 0."""
    import sympy

    from .expression import formula, symbol

    u, v = symbol("u"), symbol("v")
    lam = sympy.Symbol("lambda_scale", positive=True)
    coef, h = sympy.factor_terms(R).as_independent(u, v, as_Add=False)  # c h as a product, also c = 1 + i/10
    if not (h.free_symbols & {u, v}) or h.free_symbols - {u, v}:
        return None
    ratio = sympy.simplify(h.subs({u: lam * u, v: lam ** (1 + (sympy.nsimplify(n) - 1) / 2) * v},
                                  simultaneous=True) / h)
    if ratio.free_symbols - {lam}:
        return None
    degree = sympy.simplify(sympy.expand_log(sympy.log(ratio), force=True) / sympy.log(lam))
    at_one = h.subs({u: 1, v: 1})
    if not (degree.is_number and at_one.is_number and at_one.is_finite and at_one != 0):
        return None
    return formula(h / at_one), float(degree) - float(n)


def scaling_exponent(a: int, b: int, n: float) -> float:
    """e of x = eps c A^e for the monomial u^a v^b at contact exponent n (module docstring)."""
    return float(a) + float(b) * (float(n) + 1.0) / 2.0 - float(n)
