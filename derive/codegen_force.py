"""The generated on-site force module of the DNS: eps_i R_i(x_i, v_i) of Eq. 1, vectorised over
beads, with dF/dx and dF/dv for implicit integrators.

Arguments: ``x, v, i, eps`` then the user's parameters in ``PARAMS`` order, each named
``p_<name>`` (derive/codeprint.py), so that no parameter name shadows ``x``, ``numpy`` or
anything else of the module.

Non-smooth R (Coulomb friction ``-mu*sign(v)``, ``Heaviside``): a jump at s = 0 cannot be
integrated as it stands (a bead at rest with velocity 1e-30 ahead of the pulse feels the full
friction, overshoots, and the integrator chatters). ``sign(s)`` is integrated as the ramp
clip(s/DELTA, -1, 1) and ``Heaviside(s)`` as (1 + ramp(s))/2 with DELTA = 1e-9: the Filippov
limit (a bead sticks while the other forces stay below the friction), with errors O(DELTA) and a
stiff but exact Jacobian (slope 1/DELTA inside the ramp), which makes 'auto' pick an implicit
method. ``abs`` is continuous and kept exactly; its derivative is the ramped sign.

``MONOMIALS`` and ``monomial_coefficients(i, eps, ...)``: R as a monomial table for the compiled
DNS (None for a non-polynomial R, non-smooth ones included).

R is evaluated only on beads with eps_i != 0 (``on_perturbed``): an unperturbed bead gets 0.0
without R being computed there, so an R singular where only unperturbed beads go (u*exp(1/(u - 1))
at a bead that moves past u = 1 before first_perturbed) stops nothing; where every bead is
perturbed the expression runs as it stands (the same numbers, bit for bit).
"""

from __future__ import annotations

import sympy

from .codeprint import code, const, module, param_identifier, start
from .expression import NON_SMOOTH, parse_expression, symbol
from .monomials import polynomial_terms
from .sources import ForceSource

#: Half-width of the ramp that stands for a jump at 0 in the DNS (absolute, in the units of u and v).
DELTA = 1e-9


class ramp(sympy.Function):
    """clip(s/DELTA, -1, 1): sign(s) in the DNS (printed as the generated module's ``ramp``)."""

    def fdiff(self, argindex=1):
        return ramp_slope(self.args[0])


class ramp_slope(sympy.Function):
    """d ramp/ds: 1/DELTA inside the ramp, 0 outside (its own derivative taken as 0)."""

    def fdiff(self, argindex=1):
        return sympy.Integer(0)


def regularize(expr: sympy.Expr) -> sympy.Expr:
    """``expr`` with sign(s) -> ramp(s) and Heaviside(s) -> (1 + ramp(s))/2 (module docstring)."""
    expr = expr.replace(lambda e: isinstance(e, sympy.Heaviside), lambda e: (1 + ramp(e.args[0])) / 2)
    return expr.replace(lambda e: isinstance(e, sympy.sign), lambda e: ramp(e.args[0]))


def generate_force(source: ForceSource) -> str:
    """The text of the on-site force module (Eq. 1's eps_i R_i(x_i, v_i), vectorised)."""
    R = parse_expression(source.R, source.params)
    u, v = symbol("u"), symbol("v")
    kinks = bool(R.atoms(*NON_SMOOTH))
    ren = {u: "x", v: "v", symbol("i"): "i", **{symbol(p): param_identifier(p) for p in source.params}}
    sig = ", ".join(["x", "v", "i", "eps"] + [param_identifier(p) for p in source.params])
    lines = start(source)
    lines.append(f"PARAMS = {tuple(source.params)!r}")
    lines.append("")
    note = ""
    if kinks:
        R = regularize(R)
        note = " (sign, Heaviside as a ramp of half-width DELTA)"
        lines += [
            f"DELTA = {const(DELTA)}  # sign(s) -> clip(s/DELTA, -1, 1), Heaviside(s) -> (1 + that)/2: a jump made a ramp",
            "",
            "def ramp(s):",
            '    """sign(s) in the DNS: clip(s/DELTA, -1, 1)."""',
            "    return numpy.clip(s / DELTA, -1.0, 1.0)",
            "",
            "def ramp_slope(s):",
            '    """d ramp/ds."""',
            "    return numpy.where(numpy.abs(s) < DELTA, 1.0 / DELTA, 0.0)",
            "",
        ]
    lines += ON_PERTURBED
    for fname, expr, doc in (
        ("force", R, "eps_i R_i(x_i, v_i)"),
        ("force_dx", regularize(sympy.diff(R, u)), "d(eps_i R_i)/dx_i"),
        ("force_dv", regularize(sympy.diff(R, v)), "d(eps_i R_i)/dv_i"),
    ):
        lines.append(f"def {fname}({sig}):")
        lines.append(f'    """{doc}{note}; arrays over beads (x, v, i = bead index 1..N, eps per bead, per-bead parameters)."""')
        lines += _skip_unperturbed(fname, sig)
        lines.append(f"    return eps * ({code(expr, ren)}) + 0.0 * x")
        lines.append("")
    lines += _monomial_lines(R, ren, ", ".join(["i", "eps"] + [param_identifier(p) for p in source.params]))
    return module(lines, f"On-site force of the DNS (Eq. 1) for R(u, v) = {source.R}", source)


#: The generated module's helper: a function of the beads evaluated where eps_i != 0 only (module docstring).
ON_PERTURBED = [
    "def on_perturbed(f, eps, *args):",
    '    """f(*args) on the beads where eps_i != 0, 0.0 on the others, where R is not evaluated."""',
    "    args = numpy.broadcast_arrays(*args)",
    "    on = numpy.broadcast_to(numpy.asarray(eps) != 0.0, args[0].shape)",
    "    got = f(*(a[on] for a in args))",
    "    outs = []",
    "    for c in (got if isinstance(got, tuple) else (got,)):",
    "        out = numpy.zeros(on.shape)",
    "        out[on] = c",
    "        outs.append(out)",
    "    return tuple(outs) if isinstance(got, tuple) else outs[0]",
    "",
]


def _skip_unperturbed(fname: str, sig: str) -> list[str]:
    """The first lines of a generated function of the beads: where some eps_i = 0, itself on the others only."""
    return ["    if numpy.count_nonzero(eps) < numpy.size(eps):  # some eps_i = 0",
            f"        return on_perturbed({fname}, eps, {sig})"]


def _monomial_lines(R: sympy.Expr, ren: dict, sig: str) -> list[str]:
    """MONOMIALS (exponents (a, b) of u^a v^b; None for a non-polynomial R) and their per-bead
    coefficients: R as data for the compiled DNS (derive/monomials.py, solvers/chain/compiled.py)."""
    terms = polynomial_terms(R)
    if terms is None:
        return ["MONOMIALS = None  # R is not a polynomial in u, v: no table for the compiled DNS"]
    lines = [f"MONOMIALS = {tuple((a, b) for a, b, _ in terms)!r}", "",
             f"def monomial_coefficients({sig}):",
             '    """eps_i c_m(i) of eps_i R_i = sum_m c_m u^a_m v^b_m, one array over beads per MONOMIALS entry."""',
             *_skip_unperturbed("monomial_coefficients", sig)]
    items = "".join(f"eps * ({code(c, ren)}) + 0.0 * i, " for _, _, c in terms)
    lines.append(f"    return ({items})")
    lines.append("")
    return lines
