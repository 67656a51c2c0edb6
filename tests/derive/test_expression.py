"""Tests for pulsemap.symbolic.expression: correctness, a catalogue of hostile inputs, and properties."""

from __future__ import annotations

import builtins
import os
from contextlib import contextmanager
from typing import Iterator
from unittest import mock

import pytest
import sympy
from hypothesis import given, settings
from hypothesis import strategies as st

from pulsemap.symbolic.expression import (
    FUNCTIONS,
    MAX_LENGTH,
    SYMBOLS,
    ExpressionError,
    check_parameter_name,
    is_polynomial_in_state,
    parse_expression,
    symbol,
)

u, v, i = (symbol(name) for name in SYMBOLS)
mu = symbol("mu")


# --------------------------------------------------------------------------- correctness


@pytest.mark.parametrize(
    ("text", "params", "expected"),
    [
        ("-(u - mu*(1-u^2)*v)", ["mu"], -(u - mu * (1 - u**2) * v)),
        ("-(u - mu*(1-u**2)*v)", ["mu"], -(u - mu * (1 - u**2) * v)),
        ("0.1*u", [], sympy.Rational(1, 10) * u),
        ("1e-3*v", [], sympy.Rational(1, 1000) * v),
        ("2.5E+2 * u", [], 250 * u),
        (".5*u", [], u / 2),
        ("-u**2", [], -(u**2)),
        ("(-u)**2", [], u**2),
        ("u**2**3", [], u**8),
        ("2^-1*u", [], u / 2),
        ("u - v - i", [], u - v - i),
        ("u/v/2", [], u / v / 2),
        ("+-+u", [], -u),
        ("sin(u) + cos(v) + tan(i)", [], sympy.sin(u) + sympy.cos(v) + sympy.tan(i)),
        ("exp(u)*log(1+v**2)", [], sympy.exp(u) * sympy.log(1 + v**2)),
        ("sqrt(1+u^2)", [], sympy.sqrt(1 + u**2)),
        ("tanh(u)+sinh(v)+cosh(i)", [], sympy.tanh(u) + sympy.sinh(v) + sympy.cosh(i)),
        ("-mu*abs(v)*v", ["mu"], -mu * sympy.Abs(v) * v),
        ("-mu*sign(v)", ["mu"], -mu * sympy.sign(v)),
        ("u^(1/2)", [], sympy.sqrt(u)),
        ("  -mu * v \n", ["mu"], -mu * v),
        ("(1 + 0.01*i)*u", [], (1 + sympy.Rational(1, 100) * i) * u),
    ],
)
def test_parses_to_expected_sympy(text: str, params: list[str], expected: sympy.Expr) -> None:
    result = parse_expression(text, params)
    assert sympy.expand(result - expected) == 0
    assert result == expected or sympy.simplify(result - expected) == 0


def test_decimals_are_exact_rationals() -> None:
    expr = parse_expression("0.1*u")
    coeff = expr.coeff(u)
    assert isinstance(coeff, sympy.Rational) and coeff == sympy.Rational(1, 10)
    assert not expr.atoms(sympy.Float)


def test_symbols_are_real_and_shared() -> None:
    expr = parse_expression("u + v + i + mu", ["mu"])
    assert expr.free_symbols == {u, v, i, mu}
    assert all(s.is_real for s in expr.free_symbols)
    assert symbol("u") == symbol("u") and symbol("u").is_real
    # a user's name never equals a symbol the derivation makes for itself
    assert symbol("u") != sympy.Symbol("u", real=True)
    assert symbol("f1") != sympy.Symbol("f1", real=True)


def test_symbols_keyword_restricts_state() -> None:
    assert parse_expression("1 + i", symbols=("i",)) == 1 + i
    with pytest.raises(ExpressionError, match="'u'.*only i"):
        parse_expression("1 + u", symbols=("i",))


def test_is_polynomial_in_state() -> None:
    assert is_polynomial_in_state(parse_expression("-mu*(1-u^2)*v + sin(i)*u^3", ["mu"]))
    assert is_polynomial_in_state(parse_expression("u*v/(1+i)"))
    assert is_polynomial_in_state(sympy.Integer(0))
    assert not is_polynomial_in_state(parse_expression("sin(u)"))
    assert not is_polynomial_in_state(parse_expression("abs(v)*v"))
    assert not is_polynomial_in_state(parse_expression("u^(1/2)"))
    assert not is_polynomial_in_state(parse_expression("1/(1+u)"))
    assert not is_polynomial_in_state(parse_expression("u^i"))


# --------------------------------------------------------------------------- safety catalogue

DEEP = "(" * 500 + "u" + ")" * 500

BAD_INPUTS = [
    # (text, substring the message must contain)
    ("__import__('os').system('x')", "'__import__' is not allowed"),
    ("().__class__", "attribute access is not allowed"),
    ("u.__class__.__bases__", "attribute access is not allowed"),
    ("lambda: 1", "'lambda' is not allowed"),
    ("u.real", "attribute access is not allowed"),
    ("[u]", "'[' is not allowed"),
    ("u[0]", "'[' is not allowed"),
    ("{u}", "'{' is not allowed"),
    ('"a"', "strings are not allowed"),
    ("'a'", "strings are not allowed"),
    ("u if v else 1", "'if' is not allowed"),
    ("u; import os", "';' is not allowed"),
    ("import os", "'import' is not allowed"),
    ("u**10**10", "exponent 10000000000 is too large"),
    ("2**(2**64)", "exponent 18446744073709551616 is too large"),
    ("((2**64)**64)**64", "number too large"),
    (DEEP, "nesting too deep"),
    ("-" * 300 + "u", "nesting too deep"),
    ("u**" * 200 + "u", "nesting too deep"),
    ("inf", "non-finite number 'inf'"),
    ("nan*u", "non-finite number 'nan'"),
    ("1e999", "'1e999' is not finite"),
    ("1" * 400, "is not finite"),
    ("1e-999*u", "'1e-999' is too small"),
    ("", "empty expression"),
    ("   \n ", "empty expression"),
    ("u" * (MAX_LENGTH + 1), "too long"),
    ("sinn(u)", "unknown function 'sinn' (did you mean 'sin'?)"),
    ("eval(u)", "unknown function 'eval'"),
    ("-mu*v", "unknown symbol 'mu'"),
    ("sin(x=1)", "'=' is not allowed"),
    ("u == v", "comparisons are not allowed"),
    ("u < v", "comparisons are not allowed ('<')"),
    ("u // v", "'//' (floor division)"),
    ("u % v", "unexpected character '%'"),
    ("u @ v", "unexpected character '@'"),
    ("~u", "unexpected character '~'"),
    ("u # comment", "unexpected character '#'"),
    ("`u`", "unexpected character '`'"),
    ("\u00b5*u", "unexpected character '\u00b5'"),
    ("u\\\nv", "is not allowed"),
    ("x: u", "':' is not allowed"),
    ("2u", "unexpected 'u' after '2'"),
    ("u v", "unexpected 'v' after 'u'"),
    ("u +", "unexpected end"),
    ("(u", "')' to close"),
    ("u)", "unexpected ')'"),
    ("()", "empty parentheses"),
    ("u***v", "unexpected '*'"),
    ("sin(u, v)", "sin() takes exactly one argument"),
    ("sin()", "sin() needs exactly one argument"),
    ("sin", "'sin' is a function"),
    ("u(1)", "'u' is not a function"),
    ("(u, v)", "unexpected ','"),
    ("1/0", "division by zero"),
    ("u/(v-v)", "division by zero"),
    ("0**-1", "division by zero"),
    ("log(0)*u", "is not finite"),
    ("sqrt(-1)*u", "is complex"),
    ("eps*u", "'eps' must not appear in R"),
    ("0x1F", "unexpected 'x1F' after '0'"),
    ("1..2", "unexpected '.2'"),
    ("getattr(u)", "unknown function 'getattr'"),
    ("u\u00b2", "unexpected character '\u00b2'"),
    ("\u0663*u", "unexpected character"),
    ("globals()", "unknown function 'globals'"),
    ("open('/etc/passwd')", "strings are not allowed"),
    ("exec", "unknown symbol 'exec'"),
    ("__builtins__", "'__builtins__' is not allowed"),
    ("not u", "'not' is not allowed"),
    ("u and v", "'and' is not allowed"),
    ("[x for x in u]", "'[' is not allowed"),
    ("*u", "unexpected '*'"),
    ("u, v", "unexpected ','"),
]


@contextmanager
def _no_code_execution() -> Iterator[list[str]]:
    """Make eval/exec/compile and os.system raise or record while the parser runs."""
    calls: list[str] = []

    def forbidden(name: str):
        def _raise(*args: object, **kwargs: object) -> None:
            calls.append(name)
            raise AssertionError(f"{name} called by the parser")

        return _raise

    with mock.patch.object(builtins, "eval", forbidden("eval")), mock.patch.object(
        builtins, "exec", forbidden("exec")
    ), mock.patch.object(builtins, "compile", forbidden("compile")), mock.patch.object(
        os, "system", forbidden("os.system")
    ):
        yield calls


@pytest.mark.parametrize(("text", "fragment"), BAD_INPUTS, ids=[repr(t[:20]) for t, _ in BAD_INPUTS])
def test_bad_input_raises_clean_expression_error(text: str, fragment: str) -> None:
    with _no_code_execution() as calls:
        try:
            parse_expression(text)
        except ExpressionError as exc:
            message = str(exc)
        except Exception as exc:  # noqa: BLE001 - any other type is the failure under test
            pytest.fail(f"{type(exc).__name__} instead of ExpressionError for {text[:40]!r}: {exc}")
        else:
            pytest.fail(f"{text[:40]!r} was accepted")
    assert calls == []
    assert fragment in message, message
    assert len(message.splitlines()) == 1
    assert len(message) < 400


def test_catalogue_is_large_enough() -> None:
    assert len(BAD_INPUTS) >= 20


def test_unknown_symbol_message_names_fix_and_close_parameter() -> None:
    with pytest.raises(ExpressionError) as info:
        parse_expression("-mu*v")
    assert str(info.value) == (
        "unknown symbol 'mu' in \"-mu*v\": declare it as a parameter (--param mu=VALUE) or use u, v, i"
    )
    with pytest.raises(ExpressionError, match="did you mean 'gamma'"):
        parse_expression("-gama*v", ["gamma"])


def test_non_string_input() -> None:
    with pytest.raises(ExpressionError, match="must be a string"):
        parse_expression(1.5)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("name", "fragment"),
    [
        ("u", "displacement"),
        ("v", "displacement"),
        ("i", "displacement"),
        ("eps", "small parameter"),
        ("sin", "function name"),
        ("abs", "function name"),
        ("2mu", "invalid parameter name"),
        ("mu-1", "invalid parameter name"),
        ("_x", "invalid parameter name"),
        ("__import__", "invalid parameter name"),
        ("", "invalid parameter name"),
        ("lambda", "keyword"),
        ("inf", "non-finite"),
        ("m\u00fc", "invalid parameter name"),
    ],
)
def test_bad_parameter_names(name: str, fragment: str) -> None:
    with pytest.raises(ExpressionError, match=fragment):
        parse_expression("u", [name])
    with pytest.raises(ExpressionError):
        check_parameter_name(name)


def test_good_parameter_names() -> None:
    for name in ("mu", "k2", "gamma_1", "Mu", "E", "pi"):
        assert check_parameter_name(name) == name
        assert parse_expression(f"{name}*u", [name]) == symbol(name) * u


def test_dunder_payload_does_not_call_os_system() -> None:
    with _no_code_execution() as calls, pytest.raises(ExpressionError):
        parse_expression("__import__('os').system('echo hacked')")
    assert calls == []


# --------------------------------------------------------------------------- properties

_TOKENS = [
    "u", "v", "i", "mu", "x", "1", "0", "2.5", "1e3", "1e999", ".", "(", ")", "+", "-", "*",
    "/", "**", "^", ",", "=", "[", "]", "'", '"', ":", ";", " ", "sin", "abs", "log", "lambda",
    "__import__", "os", "system", "eps", "inf", "\n", "#", "%", "if", "else", "0.1", "64", "65",
]


@st.composite
def _token_soup(draw: st.DrawFn) -> str:
    return "".join(draw(st.lists(st.sampled_from(_TOKENS), max_size=40)))


def _warm_up() -> None:
    """Run the parser once on every construct so no lazy import happens under the patches."""
    for text in ("u", "sin(u)+cos(v)*exp(i)-log(2)/sqrt(3)^tanh(u)+sinh(v)+cosh(i)+abs(u)*sign(v)",
                 "0.1e-3**2", "1/0", "log(0)", "sqrt(-1)", "u**u**u"):
        try:
            parse_expression(text)
        except ExpressionError:
            pass


@settings(max_examples=200, deadline=None)
@given(st.one_of(st.text(max_size=80), _token_soup()))
def test_arbitrary_text_only_raises_expression_error(text: str) -> None:
    _warm_up()
    with _no_code_execution() as calls:
        try:
            result = parse_expression(text, ["mu"])
        except ExpressionError as exc:
            assert len(str(exc).splitlines()) == 1
        else:
            assert isinstance(result, sympy.Expr)
            assert result.free_symbols <= {u, v, i, mu}
            assert not result.has(sympy.zoo, sympy.nan, sympy.oo, sympy.I)
    assert calls == []


_coefficients = st.fractions(min_value=-1000, max_value=1000, max_denominator=50)
_monomials = st.tuples(st.integers(0, 5), st.integers(0, 5), _coefficients)


@settings(max_examples=200, deadline=None)
@given(st.lists(_monomials, min_size=1, max_size=6), st.booleans())
def test_polynomials_round_trip_through_str(terms: list, with_mu: bool) -> None:
    poly = sympy.Integer(0)
    for a, b, c in terms:
        coefficient = sympy.Rational(c.numerator, c.denominator)
        poly += coefficient * u**a * v**b * (mu if with_mu and a % 2 else 1)
    parsed = parse_expression(str(poly), ["mu"])
    assert sympy.expand(parsed - poly) == 0
    assert is_polynomial_in_state(parsed)


@settings(max_examples=50, deadline=None)
@given(st.floats(allow_nan=False, allow_infinity=False, min_value=-1e300, max_value=1e300))
def test_float_literals_parse_exactly(value: float) -> None:
    text = repr(value)
    parsed = parse_expression(text)
    assert parsed == sympy.Rational(text)
    assert float(parsed) == value


def test_whitelist_is_exactly_documented() -> None:
    assert set(FUNCTIONS) == {
        "sin", "cos", "tan", "exp", "log", "sqrt", "tanh", "sinh", "cosh", "abs", "sign", "heaviside", "Heaviside"
    }


@pytest.mark.parametrize("text, values, term, kind", [
    ("u*exp(1/(u-1))", {"u": 1.0 + 1e-4}, "exp(1/(u - 1))", "infinite"),  # exp(1e4) is past float64
    ("-mu*v/(u-1)", {"u": 1.0, "mu": 2.0}, "1/(u - 1)", "infinite"),
    ("sqrt(1-u)-1", {"u": 1.5}, "sqrt(1 - u)", "complex"),
    ("log(1-u)", {"u": 1.0}, "log(1 - u)", "infinite"),
    ("log(1-u)", {"u": 2.0}, "log(1 - u)", "complex"),
    ("u/(i-10)", {"u": 0.5, "i": 10.0}, "1/(i - 10)", "infinite"),
])
def test_failing_term_is_the_innermost_part_that_leaves_the_reals(text, values, term, kind):
    from pulsemap.symbolic.expression import failing_term

    expr = parse_expression(text, [k for k in values if k not in ("u", "v", "i")])
    found = failing_term(expr, {"u": 0.0, "v": 0.3, "i": 20.0, **values})
    assert (str(found[0]), found[1]) == (term, kind)


def test_failing_term_of_a_finite_value_is_none():
    from pulsemap.symbolic.expression import failing_term

    expr = parse_expression("u*exp(1/(u-1)) + sqrt(1-u)", [])
    assert failing_term(expr, {"u": 0.5, "v": 0.0, "i": 1.0}) is None
