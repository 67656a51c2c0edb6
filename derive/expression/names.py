"""The names a perturbation R may use: state symbols, whitelisted functions, limits, and the
symbol class that keeps the user's names apart from the derivation's own."""

from __future__ import annotations

from types import MappingProxyType
from typing import Mapping

import sympy

from ..errors import PulsemapError

SYMBOLS = ("u", "v", "i")
"""State symbols: displacement u = x_i, velocity v = x_i', bead index i (1-based)."""

CONTACT_SYMBOLS = ("d", "w", "k")
"""State symbols of a contact-law term P_k(d, w): overlap d = x_k - x_(k+1), its rate w = d', contact index k."""

FUNCTIONS: Mapping[str, type] = MappingProxyType(
    {
        "sin": sympy.sin,
        "cos": sympy.cos,
        "tan": sympy.tan,
        "exp": sympy.exp,
        "log": sympy.log,
        "sqrt": sympy.sqrt,
        "tanh": sympy.tanh,
        "sinh": sympy.sinh,
        "cosh": sympy.cosh,
        "abs": sympy.Abs,
        "sign": sympy.sign,
        "heaviside": sympy.Heaviside,
        "Heaviside": sympy.Heaviside,
    }
)
"""Whitelisted one-argument functions, by the name the user writes (Heaviside(0) = 1/2)."""

NON_SMOOTH = (sympy.sign, sympy.Abs, sympy.Heaviside)
"""Functions with a kink or a jump at 0: the DNS takes them (derivatives 0 almost everywhere);
the map, the long-wave law and the balances need polynomial R and refuse them."""

NON_FINITE_NAMES = frozenset({"inf", "infinity", "nan", "oo", "zoo"})
RESERVED = frozenset(SYMBOLS) | {"eps"} | frozenset(FUNCTIONS) | NON_FINITE_NAMES
"""Names that cannot be used as parameters."""

MAX_LENGTH = 2000
MAX_DEPTH = 50
MAX_EXPONENT = 64
MAX_POWER_BITS = 20000  # bound on the size of an exact number raised to a power
MAX_DECIMAL_EXPONENT = 400
MAX_NODES = 4000  # operations, symbols and numbers of R's tree: about what MAX_LENGTH characters of text can make
MAX_TERMS = 500  # additive terms of R as given: derive's time grows with them (about 3 s at 500)


class ExpressionError(PulsemapError):
    """A perturbation expression (or a parameter name) was rejected; the message says why."""


class UserSymbol(sympy.Symbol):
    """A name the user wrote in R (u, v, i or a parameter), real.

    A separate class, so that it never equals a symbol the derivation makes for itself
    (f1, g1_0010, A, B, k, epsilon, ...) even when the names are the same: sympy compares the
    type before the name. It prints as the user's own name.
    """


def symbol(name: str) -> sympy.Symbol:
    """The sympy symbol the parser creates for ``name`` (a real :class:`UserSymbol`)."""
    return UserSymbol(name, real=True)
