"""Safe parser for the on-site perturbation R_i(u, v) typed by the user.

The text is tokenised and parsed by a small recursive-descent parser that builds sympy objects
itself; user text is never passed to eval, exec, compile, sympify or parse_expr. Accepted:
numbers (decimals become exact Rationals), the symbols ``u`` (displacement x_i), ``v``
(velocity x_i'), ``i`` (1-based bead index) and declared parameter names, ``+ - * / ** ^``,
unary signs, parentheses and the one-argument functions in :data:`FUNCTIONS`.

Grammar (``**`` and ``^`` bind tighter than unary minus and are right-associative, as in
Python)::

    expr   := term (('+' | '-') term)*
    term   := unary (('*' | '/') unary)*
    unary  := ('+' | '-') unary | power
    power  := atom (('**' | '^') unary)?
    atom   := NUMBER | NAME | FUNCTION '(' expr ')' | '(' expr ')'
"""

from __future__ import annotations

import difflib
import keyword
import math
import re
from dataclasses import dataclass
from types import MappingProxyType
from typing import Iterable, Mapping

import sympy

__all__ = [
    "ExpressionError",
    "FUNCTIONS",
    "MAX_DEPTH",
    "MAX_EXPONENT",
    "MAX_LENGTH",
    "NON_SMOOTH",
    "RESERVED",
    "SYMBOLS",
    "UserSymbol",
    "check_parameter_name",
    "is_polynomial_in_state",
    "parse_expression",
    "symbol",
]

SYMBOLS = ("u", "v", "i")
"""State symbols: displacement u = x_i, velocity v = x_i', bead index i (1-based)."""

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

_NAME_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_PARAM_RE = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")
_NUMBER_RE = re.compile(r"(?:[0-9]+\.[0-9]*|\.[0-9]+|[0-9]+)(?:[eE][+-]?[0-9]+)?")
_DIGITS = "0123456789"
_WHITESPACE = " \t\r\n"
_HINT = "R is a formula in u, v, i and parameters, not Python code"


class ExpressionError(ValueError):
    """A perturbation expression (or a parameter name) was rejected; the message says why."""


@dataclass(frozen=True)
class _Token:
    kind: str  # "num", "name", "op", "end"
    text: str
    pos: int


class UserSymbol(sympy.Symbol):
    """A name the user wrote in R (u, v, i or a parameter), real.

    A separate class, so that it never equals a symbol the derivation makes for itself
    (f1, g1_0010, A, B, k, epsilon, ...) even when the names are the same: sympy compares the
    type before the name. It prints as the user's own name.
    """


def symbol(name: str) -> sympy.Symbol:
    """The sympy symbol the parser creates for ``name`` (a real :class:`UserSymbol`)."""
    return UserSymbol(name, real=True)


def check_parameter_name(name: object) -> str:
    """Return ``name`` if it may name a parameter, else raise ExpressionError."""
    if not isinstance(name, str):
        raise ExpressionError(f"parameter names must be strings, got {type(name).__name__}")
    if not _PARAM_RE.match(name):
        raise ExpressionError(
            f"invalid parameter name {_show(name)}: use letters, digits and '_', "
            "starting with a letter (e.g. mu, k2)"
        )
    if keyword.iskeyword(name) or keyword.issoftkeyword(name):
        raise ExpressionError(f"invalid parameter name {_show(name)}: it is a Python keyword")
    if name in SYMBOLS:
        raise ExpressionError(
            f"invalid parameter name {_show(name)}: u, v, i are the displacement, velocity "
            "and bead index; choose another name"
        )
    if name == "eps":
        raise ExpressionError(
            "invalid parameter name 'eps': eps is the small parameter and is given "
            "separately (eps = VALUE), not inside R"
        )
    if name in FUNCTIONS:
        raise ExpressionError(
            f"invalid parameter name {_show(name)}: it is a function name; choose another name"
        )
    if name in NON_FINITE_NAMES:
        raise ExpressionError(f"invalid parameter name {_show(name)}: it reads as a non-finite number")
    return name


def parse_expression(
    text: str, parameters: Iterable[str] = (), *, symbols: Iterable[str] = SYMBOLS
) -> sympy.Expr:
    """Parse ``text`` into a sympy expression in u, v, i and the declared ``parameters``.

    ``symbols`` restricts the state symbols allowed (e.g. ``("i",)`` for per-bead values).
    """
    params = tuple(parameters) if not isinstance(parameters, str) else (parameters,)
    for name in params:
        check_parameter_name(name)
    state = tuple(symbols)
    if not set(state) <= set(SYMBOLS):
        raise ExpressionError(f"symbols must be among {', '.join(SYMBOLS)}, got {', '.join(state)}")
    if not isinstance(text, str):
        raise ExpressionError(f"an expression must be a string, got {type(text).__name__}")
    if len(text) > MAX_LENGTH:
        raise ExpressionError(
            f"expression too long ({len(text)} characters, at most {MAX_LENGTH}): "
            "simplify it or split constants into parameters"
        )
    if not text.strip(_WHITESPACE):
        raise ExpressionError("empty expression: write R in u, v, i, e.g. \"-mu*v\"")
    tokens = _tokenize(text)
    expr = _Parser(text, tokens, frozenset(params), state).parse()
    return _check_result(expr, text)


def is_polynomial_in_state(expr: sympy.Expr) -> bool:
    """True if ``expr`` is a polynomial in u and v (coefficients may depend on anything else)."""
    return bool(sympy.sympify(expr).is_polynomial(symbol("u"), symbol("v")))


# --------------------------------------------------------------------------- helpers


def _show(token: str) -> str:
    """Quote a token (shortened) for a one-line message."""
    if len(token) > 40:
        token = token[:37] + "..."
    return "'" + _printable(token) + "'"


def _printable(text: str) -> str:
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def _context(text: str) -> str:
    """The source, quoted and shortened, for a one-line message."""
    short = text.strip(_WHITESPACE)
    if len(short) > 60:
        short = short[:57] + "..."
    return '"' + _printable(short) + '"'


def _tokenize(text: str) -> list[_Token]:
    tokens: list[_Token] = []
    pos = 0
    n = len(text)
    while pos < n:
        c = text[pos]
        if c in _WHITESPACE:
            pos += 1
            continue
        if c in _DIGITS or (c == "." and pos + 1 < n and text[pos + 1] in _DIGITS):
            m = _NUMBER_RE.match(text, pos)
            assert m is not None
            tokens.append(_Token("num", m.group(), pos))
            pos = m.end()
            continue
        if c.isascii() and (c.isalpha() or c == "_"):
            m = _NAME_RE.match(text, pos)
            assert m is not None
            name = m.group()
            _check_name_token(name, text)
            tokens.append(_Token("name", name, pos))
            pos = m.end()
            continue
        two = text[pos : pos + 2]
        if two == "**":
            tokens.append(_Token("op", "**", pos))
            pos += 2
            continue
        if two == "//":
            raise ExpressionError(f"'//' (floor division) is not allowed in {_context(text)}: use '/'")
        if two in ("==", "!=", "<=", ">="):
            raise ExpressionError(f"comparisons are not allowed ({_show(two)}): {_HINT}")
        if c in "+-*/^(),":
            tokens.append(_Token("op", "**" if c == "^" else c, pos))
            pos += 1
            continue
        raise ExpressionError(_bad_character(c, text))
    tokens.append(_Token("end", "", n))
    return tokens


def _bad_character(c: str, text: str) -> str:
    if c == ".":
        return f"attribute access is not allowed ('.' in {_context(text)}): {_HINT}"
    if c in "[]":
        return (
            f"{_show(c)} is not allowed: lists and subscripts are not supported "
            "(give per-bead values as a parameter)"
        )
    if c in "{}":
        return f"{_show(c)} is not allowed: sets and dicts are not supported; {_HINT}"
    if c in "'\"":
        return f"strings are not allowed ({_show(c)} in {_context(text)}): {_HINT}"
    if c in "<>":
        return f"comparisons are not allowed ({_show(c)}): {_HINT}"
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
        f"unexpected character {_show(c)} in {_context(text)}: "
        "use numbers, u, v, i, parameters, + - * / ** ^, parentheses and sin, cos, ..."
    )


def _check_name_token(name: str, text: str) -> None:
    if name.startswith("__"):
        raise ExpressionError(f"{_show(name)} is not allowed: {_HINT}")
    if keyword.iskeyword(name):
        extra = "; use sign() or abs() for piecewise terms" if name in ("if", "else") else ""
        raise ExpressionError(f"{_show(name)} is not allowed: {_HINT}{extra}")
    if name in NON_FINITE_NAMES:
        raise ExpressionError(
            f"non-finite number {_show(name)} is not allowed in {_context(text)}: use a finite value"
        )


def _number(token: _Token, text: str) -> sympy.Rational:
    lexeme = token.text
    mantissa, _, exponent = lexeme.lower().partition("e")
    exp10 = int(exponent) if exponent else 0
    value = sympy.Rational(mantissa)
    if value == 0:
        return sympy.Integer(0)
    if exp10 > MAX_DECIMAL_EXPONENT or not math.isfinite(float(lexeme)):
        raise ExpressionError(
            f"number {_show(lexeme)} is not finite as a float (too large) in {_context(text)}: "
            "use a value below 1e308"
        )
    if exp10 < -MAX_DECIMAL_EXPONENT or float(lexeme) == 0.0:
        raise ExpressionError(
            f"number {_show(lexeme)} is too small (it underflows to 0.0 as a float): "
            "use 0 or a value above 1e-308"
        )
    if exp10:
        value = value * sympy.Integer(10) ** exp10
    return value


def _check_result(expr: sympy.Expr, text: str) -> sympy.Expr:
    bad = (sympy.zoo, sympy.oo, -sympy.oo, sympy.nan)
    if expr.has(*bad):
        raise ExpressionError(
            f"{_context(text)} is not finite (it contains {_printable(str(expr))[:60]}): "
            "check for division by zero or log(0)"
        )
    if expr.has(sympy.I):
        raise ExpressionError(
            f"{_context(text)} is complex ({_printable(str(expr))[:60]}): R must be real, "
            "e.g. avoid sqrt or log of a negative constant"
        )
    return expr


class _Parser:
    """Recursive-descent parser over a token list; builds sympy objects."""

    def __init__(
        self, text: str, tokens: list[_Token], params: frozenset[str], state: tuple[str, ...]
    ) -> None:
        self.state = state
        self.text = text
        self.tokens = tokens
        self.params = params
        self.index = 0
        self.depth = 0

    # -- token helpers
    @property
    def tok(self) -> _Token:
        return self.tokens[self.index]

    def advance(self) -> _Token:
        token = self.tokens[self.index]
        self.index += 1
        return token

    def enter(self) -> None:
        self.depth += 1
        if self.depth > MAX_DEPTH:
            raise ExpressionError(
                f"nesting too deep (more than {MAX_DEPTH} levels of parentheses, signs or powers) "
                "in expression: simplify it"
            )

    def unexpected(self, expected: str) -> ExpressionError:
        token = self.tok
        if token.kind == "end":
            return ExpressionError(f"unexpected end of {_context(self.text)}: expected {expected}")
        previous = self.tokens[self.index - 1] if self.index else None
        if (
            previous is not None
            and previous.kind in ("num", "name")
            and token.kind in ("num", "name")
        ) or (previous is not None and previous.text == ")" and token.kind in ("num", "name")):
            return ExpressionError(
                f"unexpected {_show(token.text)} after {_show(previous.text)} at position "
                f"{token.pos} in {_context(self.text)}: use '*' for multiplication"
            )
        if token.text == ",":
            return ExpressionError(
                f"unexpected ',' at position {token.pos} in {_context(self.text)}: "
                "functions take one argument and tuples are not allowed"
            )
        return ExpressionError(
            f"unexpected {_show(token.text)} at position {token.pos} in "
            f"{_context(self.text)}: expected {expected}"
        )

    # -- grammar
    def parse(self) -> sympy.Expr:
        expr = self.expr()
        if self.tok.kind != "end":
            raise self.unexpected("an operator or the end of the expression")
        return expr

    def expr(self) -> sympy.Expr:
        self.enter()
        result = self.term()
        while self.tok.text in ("+", "-") and self.tok.kind == "op":
            op = self.advance().text
            right = self.term()
            result = result + right if op == "+" else result - right
        self.depth -= 1
        return result

    def term(self) -> sympy.Expr:
        result = self.unary()
        while self.tok.text in ("*", "/") and self.tok.kind == "op":
            op_token = self.advance()
            right = self.unary()
            if op_token.text == "*":
                result = result * right
            else:
                if right.is_zero:
                    raise ExpressionError(
                        f"division by zero at position {op_token.pos} in {_context(self.text)}"
                    )
                result = result / right
        return result

    def unary(self) -> sympy.Expr:
        if self.tok.kind == "op" and self.tok.text in ("+", "-"):
            op = self.advance().text
            self.enter()
            operand = self.unary()
            self.depth -= 1
            return -operand if op == "-" else operand
        return self.power()

    def power(self) -> sympy.Expr:
        base = self.atom()
        if self.tok.kind == "op" and self.tok.text == "**":
            op_token = self.advance()
            self.enter()
            exponent = self.unary()
            self.depth -= 1
            return self.make_power(base, exponent, op_token)
        return base

    def make_power(self, base: sympy.Expr, exponent: sympy.Expr, op_token: _Token) -> sympy.Expr:
        where = f"at position {op_token.pos} in {_context(self.text)}"
        if exponent.is_Number:
            if abs(exponent) > MAX_EXPONENT:
                raise ExpressionError(
                    f"exponent {_printable(str(exponent))[:40]} is too large {where}: "
                    f"|exponent| must be at most {MAX_EXPONENT}"
                )
            if base.is_Number:
                assert isinstance(base, sympy.Rational) and isinstance(exponent, sympy.Rational)
                bits = int(base.p).bit_length() + int(base.q).bit_length()
                if bits * max(abs(int(exponent.p)), 1) > MAX_POWER_BITS:
                    raise ExpressionError(f"number too large: the power {where} has too many digits")
        if base.is_zero and exponent.is_negative:
            raise ExpressionError(f"division by zero: 0 raised to a negative power {where}")
        return sympy.Pow(base, exponent)

    def atom(self) -> sympy.Expr:
        token = self.tok
        if token.kind == "num":
            self.advance()
            return _number(token, self.text)
        if token.kind == "name":
            self.advance()
            if self.tok.kind == "op" and self.tok.text == "(":
                return self.call(token)
            return self.name(token)
        if token.kind == "op" and token.text == "(":
            self.advance()
            self.enter()
            if self.tok.kind == "op" and self.tok.text == ")":
                raise ExpressionError(f"empty parentheses '()' at position {token.pos} in {_context(self.text)}")
            inner = self.expr()
            self.depth -= 1
            if not (self.tok.kind == "op" and self.tok.text == ")"):
                raise self.unexpected(f"')' to close the '(' at position {token.pos}")
            self.advance()
            return inner
        raise self.unexpected("a number, a symbol, a function or '('")

    def name(self, token: _Token) -> sympy.Expr:
        name = token.text
        if name in self.state or name in self.params:
            return symbol(name)
        if name in FUNCTIONS:
            raise ExpressionError(f"{_show(name)} is a function: write {name}(...)")
        if name == "eps":
            raise ExpressionError(
                "'eps' must not appear in R: eps is the small parameter and is given "
                "separately (eps = VALUE); R is multiplied by it"
            )
        if self.state != SYMBOLS:
            allowed = ", ".join(self.state) or "no symbols"
            raise ExpressionError(
                f"unknown symbol {_show(name)} in {_context(self.text)}: only {allowed} "
                "may appear here (a number or an expression of the bead index i)"
            )
        close = difflib.get_close_matches(name, sorted(self.params), n=1)
        hint = f"did you mean {_show(close[0])}? " if close else ""
        raise ExpressionError(
            f"unknown symbol {_show(name)} in {_context(self.text)}: {hint}declare it as a "
            f"parameter (--param {_printable(name)}=VALUE) or use u, v, i"
        )

    def call(self, token: _Token) -> sympy.Expr:
        name = token.text
        if name not in FUNCTIONS:
            if name in SYMBOLS or name in self.params:
                raise ExpressionError(
                    f"{_show(name)} is not a function (position {token.pos} in "
                    f"{_context(self.text)}): use '*' for multiplication"
                )
            close = difflib.get_close_matches(name, list(FUNCTIONS), n=1)
            hint = f"did you mean {_show(close[0])}?" if close else "allowed: " + ", ".join(FUNCTIONS)
            raise ExpressionError(f"unknown function {_show(name)} ({hint})")
        open_token = self.advance()
        self.enter()
        if self.tok.kind == "op" and self.tok.text == ")":
            raise ExpressionError(f"{name}() needs exactly one argument, e.g. {name}(u)")
        argument = self.expr()
        self.depth -= 1
        if self.tok.kind == "op" and self.tok.text == ",":
            raise ExpressionError(f"{name}() takes exactly one argument (',' at position {self.tok.pos})")
        if not (self.tok.kind == "op" and self.tok.text == ")"):
            raise self.unexpected(f"')' to close {name}( at position {open_token.pos}")
        self.advance()
        return FUNCTIONS[name](argument)
