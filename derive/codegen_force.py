"""The generated on-site force module of the DNS: eps_i R_i(x_i, v_i) of Eq. 1, vectorised over
beads, with dF/dx and dF/dv for implicit integrators.

Arguments: ``x, v, i, eps`` then the user's parameters in ``PARAMS`` order, each named
``p_<name>`` (derive/codeprint.py), so that no parameter name shadows ``x``, ``numpy`` or
anything else of the module.
"""

from __future__ import annotations

import sympy

from .codeprint import code, module, param_identifier, start
from .expression import parse_expression, symbol
from .sources import ForceSource


def generate_force(source: ForceSource) -> str:
    """The text of the on-site force module (Eq. 1's eps_i R_i(x_i, v_i), vectorised)."""
    R = parse_expression(source.R, source.params)
    u, v = symbol("u"), symbol("v")
    ren = {u: "x", v: "v", symbol("i"): "i", **{symbol(p): param_identifier(p) for p in source.params}}
    sig = ", ".join(["x", "v", "i", "eps"] + [param_identifier(p) for p in source.params])
    lines = start(source)
    lines.append(f"PARAMS = {tuple(source.params)!r}")
    lines.append("")
    for fname, expr, doc in (
        ("force", R, "eps_i R_i(x_i, v_i)"),
        ("force_dx", sympy.diff(R, u), "d(eps_i R_i)/dx_i"),
        ("force_dv", sympy.diff(R, v), "d(eps_i R_i)/dv_i"),
    ):
        lines.append(f"def {fname}({sig}):")
        lines.append(f'    """{doc}; arrays over beads (x, v, i = bead index 1..N, eps per bead, per-bead parameters)."""')
        lines.append(f"    return eps * ({code(expr, ren)}) + 0.0 * x")
        lines.append("")
    return module(lines, f"On-site force of the DNS (Eq. 1) for R(u, v) = {source.R}", source)
