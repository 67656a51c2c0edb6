"""Tokens of a perturbation expression and the one-line messages about them (derive/expression/expression.py)."""

from __future__ import annotations

import keyword
import math
import re
from dataclasses import dataclass

import sympy

from .names import MAX_DECIMAL_EXPONENT, NON_FINITE_NAMES, ExpressionError

_NAME_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
PARAM_RE = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")
_NUMBER_RE = re.compile(r"(?:[0-9]+\.[0-9]*|\.[0-9]+|[0-9]+)(?:[eE][+-]?[0-9]+)?")
_DIGITS = "0123456789"
WHITESPACE = " \t\r\n"
_HINT = "R is a formula in u, v, i and parameters, not Python code"


@dataclass(frozen=True)
class Token:
    kind: str  # "num", "name", "op", "end"
    text: str
    pos: int


def show(token: str) -> str:
    """Quote a token (shortened) for a one-line message."""
    if len(token) > 40:
        token = token[:37] + "..."
    return "'" + printable(token) + "'"


def printable(text: str) -> str:
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def context(text: str) -> str:
    """The source, quoted and shortened, for a one-line message."""
    short = text.strip(WHITESPACE)
    if len(short) > 60:
        short = short[:57] + "..."
    return '"' + printable(short) + '"'


def tokenize(text: str) -> list[Token]:
    tokens: list[Token] = []
    pos = 0
    n = len(text)
    while pos < n:
        c = text[pos]
        if c in WHITESPACE:
            pos += 1
            continue
        if c in _DIGITS or (c == "." and pos + 1 < n and text[pos + 1] in _DIGITS):
            m = _NUMBER_RE.match(text, pos)
            assert m is not None
            tokens.append(Token("num", m.group(), pos))
            pos = m.end()
            continue
        if c.isascii() and (c.isalpha() or c == "_"):
            m = _NAME_RE.match(text, pos)
            assert m is not None
            name = m.group()
            _check_name_token(name, text)
            tokens.append(Token("name", name, pos))
            pos = m.end()
            continue
        two = text[pos : pos + 2]
        if two == "**":
            tokens.append(Token("op", "**", pos))
            pos += 2
            continue
        if two == "//":
            raise ExpressionError(f"'//' (floor division) is not allowed in {context(text)}: use '/'")
        if two in ("==", "!=", "<=", ">="):
            raise ExpressionError(f"comparisons are not allowed ({show(two)}): {_HINT}")
        if c in "+-*/^(),":
            tokens.append(Token("op", "**" if c == "^" else c, pos))
            pos += 1
            continue
        raise ExpressionError(_bad_character(c, text))
    tokens.append(Token("end", "", n))
    return tokens


def _bad_character(c: str, text: str) -> str:
    if c == ".":
        return f"attribute access is not allowed ('.' in {context(text)}): {_HINT}"
    if c in "[]":
        return (
            f"{show(c)} is not allowed: lists and subscripts are not supported "
            "(give per-bead values as a parameter)"
        )
    if c in "{}":
        return f"{show(c)} is not allowed: sets and dicts are not supported; {_HINT}"
    if c in "'\"":
        return f"strings are not allowed ({show(c)} in {context(text)}): {_HINT}"
    if c in "<>":
        return f"comparisons are not allowed ({show(c)}): {_HINT}"
    if c == "=":
        return (
            "'=' is not allowed: no assignments or keyword arguments; "
            "give parameter values separately (--param NAME=VALUE)"
        )
    if c == ";":
        return f"';' is not allowed: give a single expression; {_HINT}"
    if c == ":":
        return f"':' is not allowed (no lambdas, slices or annotations): {_HINT}"
    if c == "\\":
        return "'\\\\' is not allowed: write the expression on one line or in plain text"
    return (
        f"unexpected character {show(c)} in {context(text)}: "
        "use numbers, u, v, i, parameters, + - * / ** ^, parentheses and sin, cos, ..."
    )


def _check_name_token(name: str, text: str) -> None:
    if name.startswith("__"):
        raise ExpressionError(f"{show(name)} is not allowed: {_HINT}")
    if keyword.iskeyword(name):
        extra = "; use sign() or abs() for piecewise terms" if name in ("if", "else") else ""
        raise ExpressionError(f"{show(name)} is not allowed: {_HINT}{extra}")
    if name in NON_FINITE_NAMES:
        raise ExpressionError(
            f"non-finite number {show(name)} is not allowed in {context(text)}: use a finite value"
        )


def number(token: Token, text: str) -> sympy.Rational:
    lexeme = token.text
    mantissa, _, exponent = lexeme.lower().partition("e")
    exp10 = int(exponent) if exponent else 0
    value = sympy.Rational(mantissa)
    if value == 0:
        return sympy.Integer(0)
    if exp10 > MAX_DECIMAL_EXPONENT or not math.isfinite(float(lexeme)):
        raise ExpressionError(
            f"number {show(lexeme)} is not finite as a float (too large) in {context(text)}: "
            "use a value below 1e308"
        )
    if exp10 < -MAX_DECIMAL_EXPONENT or float(lexeme) == 0.0:
        raise ExpressionError(
            f"number {show(lexeme)} is too small (it underflows to 0.0 as a float): "
            "use 0 or a value above 1e-308"
        )
    if exp10:
        value = value * sympy.Integer(10) ** exp10
    return value
