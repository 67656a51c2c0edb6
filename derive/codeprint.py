"""Printing sympy as numpy code for the generated modules, with the user's names kept apart.

A generated module's own identifiers (``numpy``, ``f1``, ``S0``, ``A``, ``a_prev``, ``eps``, ``x``,
...) never start with ``p_`` or ``b0_``/``b1_``/``b2_``; a user's parameter ``name`` is the
argument ``p_<name>`` (uniform) or ``b<offset>_<name>`` (its value at bead i + offset). So no
parameter name the parser accepts can shadow a module global, ``numpy``, another argument or a
local, and the map back to the user's name is a prefix strip.
"""

from __future__ import annotations

import hashlib
import json
import keyword
import math

import sympy
from sympy.printing.numpy import NumPyPrinter
from sympy.printing.pycode import PythonCodePrinter

from .expansion import BeadSymbol, bead_symbol
from .expression import SYMBOLS, UserSymbol, symbol
from .profile import get_profile

SIG_DIGITS = 12  # most digits printed of a constant: finer than the profile constants' accuracy (~1e-10), so rounding adds no error that matters


class CodegenError(RuntimeError):
    """An internal inconsistency while writing a module (a symbol without an identifier)."""


def param_identifier(name: str, offset: int | None = None) -> str:
    """The generated code's argument for parameter ``name`` (uniform), or for its value at bead
    i + ``offset`` (site-dependent)."""
    return f"p_{name}" if offset is None else f"b{offset}_{name}"


def _is_user_identifier(ident: str) -> bool:
    return ident.startswith("p_") or (len(ident) > 3 and ident[0] == "b" and ident[1] in "012" and ident[2] == "_")


def _is_parameter(s: sympy.Symbol) -> bool:
    """True for a user's parameter (or its value at one bead), False for u, v, i and internal symbols."""
    return isinstance(s, BeadSymbol) or (isinstance(s, UserSymbol) and s.name not in SYMBOLS)


class _RampPrinter:
    """ramp(s) and ramp_slope(s) (derive/codegen_force.py) as calls of the generated module's own functions."""

    def _print_ramp(self, expr):
        return f"ramp({self._print(expr.args[0])})"

    def _print_ramp_slope(self, expr):
        return f"ramp_slope({self._print(expr.args[0])})"


class _Printer(_RampPrinter, NumPyPrinter):
    """numpy code; Heaviside(x) as numpy.heaviside(x, 0.5) (sympy's H(0) = 1/2)."""

    def _print_Heaviside(self, expr):
        return f"numpy.heaviside({self._print(expr.args[0])}, 0.5)"


class _MathPrinter(_RampPrinter, PythonCodePrinter):
    """Scalar code with the math module (numba compiles it), for derive/codegen_jitforce.py."""

    def _print_not_supported(self, expr):
        raise CodegenError(f"{expr} has no scalar (math module) form for the compiled DNS")


def code(expr: sympy.Expr, names: dict[sympy.Symbol, str], scalar: bool = False) -> str:
    """numpy code for ``expr`` (``scalar``: math-module code for one bead), each free symbol printed
    as its identifier in ``names``.

    Every free symbol must have an identifier, and distinct symbols distinct identifiers: two
    symbols printed alike would silently become one variable of the module.
    """
    expr = sympy.sympify(expr)
    free = expr.free_symbols
    missing = [s for s in free if s not in names]
    if missing:
        raise CodegenError(f"no identifier for symbol(s) {', '.join(sorted(map(str, missing)))} in generated code")
    used = {s: names[s] for s in free}
    if len(set(used.values())) != len(used):
        raise CodegenError(f"two symbols share an identifier in generated code: {sorted(used.values())}")
    for s, ident in used.items():
        if not ident.isidentifier() or keyword.iskeyword(ident):
            raise CodegenError(f"{ident!r} is not a Python identifier")
        if _is_user_identifier(ident) != _is_parameter(s):
            raise CodegenError(f"identifier {ident!r} of {s} crosses the user/internal namespaces")
    expr = expr.xreplace({s: sympy.Symbol(ident, real=True) for s, ident in used.items()})
    printer = _MathPrinter if scalar else _Printer
    return printer({"fully_qualified_modules": True}).doprint(expr)


def const(value: float) -> str:
    """A constant rounded to SIG_DIGITS significant digits, as Python source."""
    return repr(float(f"{value:.{SIG_DIGITS}g}"))


def measured(value: float, error: float) -> float:
    """A computed constant to the digits it is accurate to: rounded at the decade of its error bound
    (at most SIG_DIGITS significant digits). Digits below the bound move with the machine (a profile
    from another numpy build differs at 1e-13); rounded there, the printed constant, and so the
    generated file, is the same on every machine unless the value sits on a rounding boundary."""
    if error > 0 and math.isfinite(error):
        value = round(value, -math.floor(math.log10(error)))
    return float(const(value))


def profile_peak(profile: str, n: float) -> float:
    """S(0) of the profile, to the digits it is accurate to (its accuracy is relative to S(0))."""
    prof = get_profile(profile, n)
    return measured(prof.S0, prof.accuracy * prof.S0)


def param_args(source, terms, offsets: tuple[int, ...]) -> tuple[list[str], list[tuple[str, int]], dict]:
    """The generated functions' parameter arguments: (identifiers, (name, offset) of each, renaming).

    A uniform parameter is one argument; a site-dependent one is an argument per bead offset the
    expansion ``terms`` use. The bead index i, when R depends on it, comes last as ("i", 0) (no
    parameter may be called i).
    """
    site = set(source.site_dependent)
    idents: list[str] = []
    described: list[tuple[str, int]] = []
    ren: dict[sympy.Symbol, str] = {}
    for name in source.params:
        if name in site:
            for off in offsets:
                sym = bead_symbol(name, off)
                if any(sym in t.coefficient.free_symbols for t in terms):
                    ren[sym] = param_identifier(name, off)
                    idents.append(ren[sym])
                    described.append((name, off))
        else:
            ren[symbol(name)] = param_identifier(name)
            idents.append(ren[symbol(name)])
            described.append((name, 0))
    if any(symbol("i") in t.coefficient.free_symbols for t in terms):
        ren[symbol("i")] = "i"
        idents.append("i")
        described.append(("i", 0))
    return idents, described, ren


# ------------------------------------------------------------------ module text
def _header(title: str, source, body: str) -> str:
    from .sources import source_hash

    content = hashlib.sha256(body.encode()).hexdigest()
    return (
        "# Generated by pulsemap (derive/codegen.py). Do not edit: regenerate with pulsemap.symbolic.codegen.\n"
        f'"""{title}\n\n'
        f"source: {json.dumps(source.as_dict(), sort_keys=True)}\n"
        f"source-hash: {source_hash(source)}\n"
        f"content-hash: {content}\n"
        '"""\n'
    )


def start(source) -> list[str]:
    """The first lines of every generated module: the numpy import and its SOURCE."""
    return ["import numpy", "", f"SOURCE = {json.dumps(source.as_dict(), sort_keys=True)}"]


def title(what: str, source, tail: str = "") -> str:
    """A map or balance module's title: what it holds, then R, n, profile and dps (``tail`` appended)."""
    return (
        f"{what} for\n"
        f"    R(u, v) = {source.R}\n"
        f"    n = {source.n}, profile = {source.profile} (mpmath dps {source.dps}){tail}"
    )


def module(lines: list[str], title_text: str, source) -> str:
    """The module text: its header (title, source and hashes) and ``lines`` as the body."""
    body = "\n".join(lines).rstrip() + "\n"
    return _header(title_text, source, body) + body
