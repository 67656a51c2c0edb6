"""Recursive-descent parser of a perturbation expression (grammar in derive/expression/expression.py): builds
sympy objects itself from tokens; user text never reaches eval, sympify or parse_expr."""

from __future__ import annotations

import sympy

from ..errors import closest
from .names import CONTACT_SYMBOLS, FUNCTIONS, MAX_DEPTH, MAX_EXPONENT, MAX_POWER_BITS, SYMBOLS, ExpressionError, symbol
from .tokens import Token, context, number, printable, show

class Parser:
    """Recursive-descent parser over a token list; builds sympy objects."""

    def __init__(
        self, text: str, tokens: list[Token], params: frozenset[str], state: tuple[str, ...]
    ) -> None:
        self.state = state
        self.text = text
        self.tokens = tokens
        self.params = params
        self.index = 0
        self.depth = 0

    # -- token helpers
    @property
    def tok(self) -> Token:
        return self.tokens[self.index]

    def advance(self) -> Token:
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
            return ExpressionError(f"unexpected end of {context(self.text)}: expected {expected}")
        previous = self.tokens[self.index - 1] if self.index else None
        if (
            previous is not None
            and previous.kind in ("num", "name")
            and token.kind in ("num", "name")
        ) or (previous is not None and previous.text == ")" and token.kind in ("num", "name")):
            return ExpressionError(
                f"unexpected {show(token.text)} after {show(previous.text)} at position "
                f"{token.pos} in {context(self.text)}: use '*' for multiplication"
            )
        if token.text == ",":
            return ExpressionError(
                f"unexpected ',' at position {token.pos} in {context(self.text)}: "
                "functions take one argument and tuples are not allowed"
            )
        return ExpressionError(
            f"unexpected {show(token.text)} at position {token.pos} in "
            f"{context(self.text)}: expected {expected}"
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
                        f"division by zero at position {op_token.pos} in {context(self.text)}"
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

    def make_power(self, base: sympy.Expr, exponent: sympy.Expr, op_token: Token) -> sympy.Expr:
        where = f"at position {op_token.pos} in {context(self.text)}"
        if exponent.is_Number:
            if abs(exponent) > MAX_EXPONENT:
                raise ExpressionError(
                    f"exponent {printable(str(exponent))[:40]} is too large {where}: "
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
            return number(token, self.text)
        if token.kind == "name":
            self.advance()
            if self.tok.kind == "op" and self.tok.text == "(":
                return self.call(token)
            return self.name(token)
        if token.kind == "op" and token.text == "(":
            self.advance()
            self.enter()
            if self.tok.kind == "op" and self.tok.text == ")":
                raise ExpressionError(f"empty parentheses '()' at position {token.pos} in {context(self.text)}")
            inner = self.expr()
            self.depth -= 1
            if not (self.tok.kind == "op" and self.tok.text == ")"):
                raise self.unexpected(f"')' to close the '(' at position {token.pos}")
            self.advance()
            return inner
        raise self.unexpected("a number, a symbol, a function or '('")

    def name(self, token: Token) -> sympy.Expr:
        name = token.text
        if name in self.state or name in self.params:
            return symbol(name)
        if name in FUNCTIONS:
            raise ExpressionError(f"{show(name)} is a function: write {name}(...)")
        if name == "eps":
            raise ExpressionError(
                "'eps' must not appear in R: eps is the small parameter and is given "
                "separately (eps = VALUE); R is multiplied by it"
            )
        if self.state == CONTACT_SYMBOLS:
            where = ("u, v, i belong in R ([perturbation]); P is a formula in the overlap d, its rate w and the "
                     "contact index k" if name in SYMBOLS else "declare it in [contact.params] or use d, w, k")
            raise ExpressionError(f"unknown symbol {show(name)} in {context(self.text)}: {where}")
        if self.state != SYMBOLS:
            allowed = ", ".join(self.state) or "no symbols"
            raise ExpressionError(
                f"unknown symbol {show(name)} in {context(self.text)}: only {allowed} "
                "may appear here (a number or an expression of the bead index i)"
            )
        close = closest(name, sorted(self.params))
        hint = f"did you mean {show(close)}? " if close else ""
        raise ExpressionError(
            f"unknown symbol {show(name)} in {context(self.text)}: {hint}declare it as a "
            f"parameter (--param {printable(name)}=VALUE) or use u, v, i"
        )

    def call(self, token: Token) -> sympy.Expr:
        name = token.text
        if name not in FUNCTIONS:
            if name in SYMBOLS or name in self.state or name in self.params:
                raise ExpressionError(
                    f"{show(name)} is not a function (position {token.pos} in "
                    f"{context(self.text)}): use '*' for multiplication"
                )
            close = closest(name, FUNCTIONS)
            hint = f"did you mean {show(close)}?" if close else "allowed: " + ", ".join(FUNCTIONS)
            raise ExpressionError(f"unknown function {show(name)} ({hint})")
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
