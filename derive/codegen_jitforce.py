"""The generated numba force module of the compiled DNS: eps_i R_i(x_i, v_i) of Eq. 1 for one bead,
with dF/dx and dF/dv, for an R that is not a polynomial (sin(u), exp(-v^2) u, v/(1 + v^2), ...).

    x_i'' = (x_{i-1} - x_i)_+^n - (x_i - x_{i+1})_+^n + eps_i R_i(x_i, x_i')          (paper Eq. 1)

Three C-callable functions (numba ``cfunc`` as chain/jit.py makes it, compiled once and cached on disk),
each ``f(x, v, i, p) -> float`` with x, v the bead's displacement and velocity, i its index (1-based)
and p a pointer to [eps_i, then the parameters in PARAMS order at that bead]. R is evaluated only where
eps_i != 0 (0.0 is returned at an unperturbed bead: an R singular where only unperturbed beads go
cannot stop the run). Compiled with numba's numpy error model: a division by zero gives inf, never an
exception from inside the kernel; a non-finite value stops the run with the bead and time located
(solvers/chain/dns.py). The compiled kernels
call them through a function pointer (solvers/chain/compiled_force.py), so one compiled kernel
serves every R. The module lives in the cache only (derive never imports numba: this is text).

Non-smooth R (sign, Heaviside, abs) is integrated as the scipy engine's force module integrates it
(derive/codegen_force.py): sign(s) as the ramp clip(s/DELTA, -1, 1), Heaviside(s) as (1 + ramp(s))/2,
abs kept exactly with the ramp as its slope; dF/dx and dF/dv are the ramp's exact slopes (1/DELTA inside
it, 0 outside). Both engines so integrate the same equations (the Filippov limit up to O(DELTA): a bead
sticks while the other forces on it stay below the friction); the stiff ramp makes 'auto' take Rodas4.
"""

from __future__ import annotations

import json

import sympy

from .codegen_force import DELTA, regularize
from .codeprint import code, const, module, param_identifier
from .expression import NON_SMOOTH, parse_expression, symbol
from .sources import JitForceSource

SIGNATURE = "types.float64(types.float64, types.float64, types.float64, types.CPointer(types.float64))"
#: The generated module's ramp (sign(s) in the DNS) and its slope, scalar and compiled (module docstring).
RAMP = [
    f"DELTA = {const(DELTA)}  # sign(s) -> clip(s/DELTA, -1, 1), Heaviside(s) -> (1 + that)/2: a jump made a ramp",
    "",
    "",
    "@njit(cache=True, inline=\"always\")",
    "def ramp(s):",
    '    """sign(s) in the DNS: clip(s/DELTA, -1, 1)."""',
    "    return min(max(s / DELTA, -1.0), 1.0)",
    "",
    "",
    "@njit(cache=True, inline=\"always\")",
    "def ramp_slope(s):",
    '    """d ramp/ds: 1/DELTA inside the ramp, 0 outside."""',
    "    return 1.0 / DELTA if abs(s) < DELTA else 0.0",
    "",
]


def generate_jit_force(source: JitForceSource) -> str:
    """The text of the numba force module for ``source`` (module docstring); CodegenError when R
    has a function without a math-module form."""
    R = parse_expression(source.R, source.params)
    kinks = bool(R.atoms(*NON_SMOOTH))
    if kinks:
        R = regularize(R)
    u, v = symbol("u"), symbol("v")
    ren = {u: "x", v: "v", symbol("i"): "i", **{symbol(p): param_identifier(p) for p in source.params}}
    unpack = ["    eps = p[0]", "    if eps == 0.0:", "        return 0.0  # R is not evaluated at an unperturbed bead"]
    unpack += [f"    {param_identifier(name)} = p[{k + 1}]" for k, name in enumerate(source.params)]
    lines = ["import math", "", f"from pulsemap.solvers.chain.jit import cfunc, {'njit, ' if kinks else ''}types", "",
             f"SOURCE = {json.dumps(source.as_dict(), sort_keys=True)}", f"PARAMS = {tuple(source.params)!r}",
             f"SIGNATURE = {SIGNATURE}", *(RAMP if kinks else [""])]
    for fname, expr, doc in (("force", R, "eps_i R_i(x, v)"),
                             ("force_dx", regularize(sympy.diff(R, u)), "d(eps_i R_i)/dx"),
                             ("force_dv", regularize(sympy.diff(R, v)), "d(eps_i R_i)/dv")):
        lines += ["", '@cfunc(SIGNATURE, cache=True, error_model="numpy")', f"def {fname}(x, v, i, p):",
                  f'    """{doc} at bead i (1-based); p: [eps_i, then PARAMS at bead i]."""', *unpack,
                  f"    return eps * ({code(expr, ren, scalar=True)})", ""]
    return module(lines, f"On-site force of the compiled DNS (Eq. 1, numba) for R(u, v) = {source.R}", source)
