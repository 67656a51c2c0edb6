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

import keyword
import math
from typing import Iterable

import sympy

from .names import (CONTACT_SYMBOLS, FUNCTIONS, MAX_EXPONENT, MAX_LENGTH, MAX_NODES, MAX_TERMS, NON_FINITE_NAMES,
                    SYMBOLS, ExpressionError, symbol)
from .parser import Parser
from .tokens import PARAM_RE, WHITESPACE, context, printable, show, tokenize

__all__ = ["check_parameter_name", "formula", "is_polynomial_in_state", "parse_expression", "singular_terms",
           "total_degree"]


class _FormulaPrinter(sympy.printing.str.StrPrinter):
    """sympy's text with the parser's function names (abs, exp(1)), so that the text parses back."""

    def _print_Abs(self, expr: sympy.Abs) -> str:
        return f"abs({self._print(expr.args[0])})"

    def _print_Exp1(self, expr: sympy.Expr) -> str:
        return "exp(1)"


def formula(expr: sympy.Expr) -> str:
    """A sympy R as the text :func:`parse_expression` reads (a scene file's R, the generated force's source)."""
    return _FormulaPrinter().doprint(expr)


def free_names(text: str, known: Iterable[str]) -> list[str]:
    """Names in ``text`` that may name a parameter and are not ``known`` (given a value, or a symbol of the
    expression such as P's d, w, k), in order; names called as functions and the parser's other errors are left
    for the parser to report."""
    known, found = set(known), []
    tokens = tokenize(text)
    for token, after in zip(tokens, tokens[1:] + [None]):
        if after is not None and after.text == "(":
            continue  # a call: the parser names the unknown function and the closest known one
        if token.kind == "name" and token.text not in known and token.text not in found:
            try:
                check_parameter_name(token.text)
            except ExpressionError:
                continue
            found.append(token.text)
    return found


def check_parameter_name(name: object) -> str:
    """Return ``name`` if it may name a parameter, else raise ExpressionError."""
    if not isinstance(name, str):
        raise ExpressionError(f"parameter names must be strings, got {type(name).__name__}")
    if not PARAM_RE.match(name):
        raise ExpressionError(
            f"invalid parameter name {show(name)}: use letters, digits and '_', "
            "starting with a letter (e.g. mu, k2)"
        )
    if keyword.iskeyword(name) or keyword.issoftkeyword(name):
        raise ExpressionError(f"invalid parameter name {show(name)}: it is a Python keyword")
    if name in SYMBOLS:
        raise ExpressionError(
            f"invalid parameter name {show(name)}: u, v, i are the displacement, velocity "
            "and bead index; choose another name"
        )
    if name == "eps":
        raise ExpressionError(
            "invalid parameter name 'eps': eps is the small parameter and is given "
            "separately (eps = VALUE), not inside R"
        )
    if name in FUNCTIONS:
        raise ExpressionError(
            f"invalid parameter name {show(name)}: it is a function name; choose another name"
        )
    if name in NON_FINITE_NAMES:
        raise ExpressionError(f"invalid parameter name {show(name)}: it reads as a non-finite number")
    return name


def parse_expression(
    text: str, parameters: Iterable[str] = (), *, symbols: Iterable[str] = SYMBOLS
) -> sympy.Expr:
    """Parse ``text`` into a sympy expression in u, v, i and the declared ``parameters``.

    ``symbols`` restricts the state symbols allowed (e.g. ``("i",)`` for per-bead values) or names the
    contact law's (names.CONTACT_SYMBOLS: d, w, k).
    """
    params = tuple(parameters) if not isinstance(parameters, str) else (parameters,)
    for name in params:
        check_parameter_name(name)
    state = tuple(symbols)
    if not (set(state) <= set(SYMBOLS) or set(state) <= set(CONTACT_SYMBOLS)):
        raise ExpressionError(f"symbols must be among {', '.join(SYMBOLS)} or {', '.join(CONTACT_SYMBOLS)}, "
                              f"got {', '.join(state)}")
    if not isinstance(text, str):
        raise ExpressionError(f"an expression must be a string, got {type(text).__name__}")
    if len(text) > MAX_LENGTH:
        raise ExpressionError(
            f"expression too long ({len(text)} characters, at most {MAX_LENGTH}): "
            "simplify it or split constants into parameters"
        )
    if not text.strip(WHITESPACE):
        raise ExpressionError("empty expression: write R in u, v, i, e.g. \"-mu*v\"")
    tokens = tokenize(text)
    expr = Parser(text, tokens, frozenset(params), state).parse()
    return _check_result(expr, text)


def is_polynomial_in_state(expr: sympy.Expr) -> bool:
    """True if ``expr`` is a polynomial in u and v (coefficients may depend on anything else)."""
    return bool(sympy.sympify(expr).is_polynomial(symbol("u"), symbol("v")))


def total_degree(expr: sympy.Expr, names: tuple[str, ...] = SYMBOLS) -> int:
    """An upper bound on the total degree of ``expr`` in u, v, i, read off its tree without expanding
    it: sums over products, maxima over sums, degree times |exponent| over numeric powers (so
    ``((u^64)^64)^64`` and ``u*u*...*u`` count what they are); a function counts its argument. The state
    symbols (``names``: u, v, i, or the contact law's d, w, k) are known by name (a sympy R from Python is counted
    before its symbols are replaced)."""
    if isinstance(expr, sympy.Symbol):
        return int(expr.name in names)
    if not any(s.name in names for s in expr.free_symbols if isinstance(s, sympy.Symbol)):
        return 0
    if isinstance(expr, sympy.Pow) and expr.exp.is_Number:
        return total_degree(expr.base, names) * math.ceil(abs(expr.exp))
    degrees = [total_degree(arg, names) for arg in expr.args]
    if isinstance(expr, sympy.Mul) or isinstance(expr, sympy.Pow):
        return sum(degrees)
    return max(degrees, default=0)


def singular_terms(expr: sympy.Expr) -> list[sympy.Expr]:
    """The parts of ``expr`` that are infinite somewhere in u, v, i: negative powers of an expression
    of the state (1/(u - 1)), and log or tan of one; in the order they appear."""
    state = {symbol(name) for name in SYMBOLS}
    found: list[sympy.Expr] = []
    for node in sympy.preorder_traversal(sympy.sympify(expr)):
        if not node.free_symbols & state or node in found:
            continue
        if (isinstance(node, sympy.Pow) and node.exp.is_negative) or isinstance(node, (sympy.log, sympy.tan)):
            found.append(node)
    return found


def failing_term(expr: sympy.Expr, values: dict[str, float]) -> tuple[sympy.Expr, str] | None:
    """The innermost part of ``expr`` that is not a finite real float64 at ``values`` (u, v, i and the
    parameters, by name) with what it is there ("infinite", "complex" or "not a number"); None when
    every part is finite and real. Each part is evaluated by the math module on floats (sympy's own
    numbers do not overflow)."""
    names = sorted(expr.free_symbols, key=str)
    args = [float(values[str(s)]) for s in names]

    def value(node: sympy.Expr, module: str = "math") -> str | None:
        try:
            got = sympy.lambdify(names, node, modules=module)(*args)
        except (OverflowError, ZeroDivisionError):
            return "infinite"
        except ValueError:  # a domain error: log(0) (cmath too), or log or sqrt of a negative number
            return "infinite" if module == "cmath" else (value(node, "cmath") or "complex")
        if isinstance(got, complex) and got.imag != 0.0:
            return "complex"
        got = abs(got) if isinstance(got, complex) else float(got)
        return None if math.isfinite(got) else ("not a number" if math.isnan(got) else "infinite")

    for node in sympy.postorder_traversal(expr):
        if node.free_symbols and not node.is_Atom:
            kind = value(node)
            if kind is not None:
                return node, kind
    return None


def bound_size(expr: sympy.Expr, what: str) -> None:
    """Refuse ``expr`` (named ``what`` in the message) beyond the bounds every door of R shares: MAX_TERMS
    additive terms, MAX_NODES nodes of its tree, total degree MAX_EXPONENT in u, v, i. Counted without
    expanding, and stopped at the bound, so a huge expression is refused at once."""
    terms = len(sympy.Add.make_args(expr))
    if terms > MAX_TERMS:
        raise ExpressionError(f"{what} has {terms} terms, more than {MAX_TERMS}: collect terms or move sums of "
                              "constants into parameters")
    for count, _ in enumerate(sympy.preorder_traversal(expr), start=1):
        if count > MAX_NODES:
            raise ExpressionError(f"{what} has more than {MAX_NODES} nodes (operations, symbols, numbers): "
                                  "simplify it or move constants into parameters")
    degree = max(total_degree(expr), total_degree(expr, CONTACT_SYMBOLS))
    if degree > MAX_EXPONENT:
        raise ExpressionError(
            f"{what} has total degree {degree} in u, v, i, more than {MAX_EXPONENT}: "
            "lower the powers (repeated products and powers of powers multiply the degree)"
        )


def _check_result(expr: sympy.Expr, text: str) -> sympy.Expr:
    bound_size(expr, context(text))
    bad = (sympy.zoo, sympy.oo, -sympy.oo, sympy.nan)
    if expr.has(*bad):
        raise ExpressionError(
            f"{context(text)} is not finite (it contains {printable(str(expr))[:60]}): "
            "check for division by zero or log(0)"
        )
    if expr.has(sympy.I):
        raise ExpressionError(
            f"{context(text)} is complex ({printable(str(expr))[:60]}): R must be real, "
            "e.g. avoid sqrt or log of a negative constant"
        )
    return expr
