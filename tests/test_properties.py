"""Property-based tests (hypothesis) of the user-facing parsers and of the derivation.

* Arbitrary strings -- random text and a token soup laced with Python payloads -- given as R, as
  a parameter value, as eps, or inside a scene, never execute code (eval/exec/compile, os.system,
  subprocess and file creation are trapped, and a sentinel file must not appear) and either
  parse or raise the layer's own ValueError subclass with a one-line message.
* Random expressions drawn from the documented grammar always parse, and to the right value:
  the parsed sympy expression, evaluated at a point, equals an independent float evaluation of
  the same tree.
* Random polynomial perturbations sum_j c_j u^a_j v^b_j derive without error through
  derive_all, and the derivation's monomials, powers of A (map, Eq. 23) and powers of B
  (long-wave law, Eq. 30) equal an independent count: binomial expansion of Eq. 12 done here
  with integers and fractions, not with sympy.

Settings: text/token properties max_examples=150, grammar 150,
derivation 10; all deadline=None; derivation with sympy_seconds=0 (quadrature law, no forked
closed-form attempt), so the whole file runs in ~15 s on a cold cache.
"""

from __future__ import annotations

import builtins
import math
import os
import subprocess
from contextlib import contextmanager
from fractions import Fraction
from math import comb
from pathlib import Path
from typing import Iterator
from unittest import mock

import pytest
import sympy
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pulsemap.symbolic.expression import parse_expression, symbol
from pulsemap.symbolic.perturbation import PerturbationError, make_perturbation

U, V, I, MU = (symbol(name) for name in ("u", "v", "i", "mu"))
SENTINEL = Path(os.environ.get("TMPDIR", "/tmp")) / "pulsemap-property-sentinel"

# --------------------------------------------------------------------------- no code execution


@contextmanager
def trapped() -> Iterator[list[str]]:
    """Every way user text could run code or touch the system records a call and raises."""
    calls: list[str] = []

    def forbidden(name: str):
        def _raise(*args: object, **kwargs: object):
            calls.append(name)
            raise AssertionError(f"{name} called while parsing user text")

        return _raise

    targets = [(builtins, "eval"), (builtins, "exec"), (builtins, "compile"), (builtins, "open"),
               (os, "system"), (os, "popen"), (os, "remove"), (subprocess, "Popen")]
    patches = [mock.patch.object(obj, name, forbidden(f"{getattr(obj, '__name__', obj)}.{name}"))
               for obj, name in targets]
    for p in patches:
        p.start()
    try:
        yield calls
    finally:
        for p in reversed(patches):
            p.stop()


def _warm_up() -> None:
    """Exercise every construct once outside the trap, so no lazy import compiles under it."""
    for text in ("u", "sin(u)+cos(v)*exp(i)-log(2)/sqrt(3)^tanh(u)+sinh(v)+cosh(i)+abs(u)*sign(v)",
                 "0.1e-3**2", "1/0", "log(0)", "sqrt(-1)", "u**u**u", "-(u - mu*(1-u^2)*v)"):
        for call in (lambda: parse_expression(text, ["mu"]), lambda: make_perturbation(text, "0.1", {"mu": "1+i"})):
            try:
                call()
            except ValueError:
                pass
    from pulsemap.solvers.data.scene import parse_scene

    try:
        parse_scene(_scene_data("-mu*v", 1.0), "warm.toml")
    except ValueError:
        pass


PAYLOADS = [
    f"__import__('pathlib').Path('{SENTINEL}').touch()",
    f"open('{SENTINEL}','w')",
    "__import__('os').system('touch " + str(SENTINEL) + "')",
    "exec('import os')", "eval('1')", "compile('1','','eval')", "lambda: 0", "().__class__.__bases__[0]",
    "u.__class__", "globals()", "getattr(u, 'x')", "[x for x in (1,)]", "import os", "__builtins__",
    "breakpoint()", "input()", "sympy.sympify('u')", "S('u')", "Symbol('x')", "u if v else 1",
]
TOKENS = ["u", "v", "i", "mu", "eps", "1", "0", "2.5", "1e3", "1e400", "nan", "inf", "+", "-", "*", "/",
          "**", "^", "(", ")", ",", ".", "sin", "exp", "log", "sqrt", "abs", " ", "=", ";", ":", "'", "[", "]",
          "__", "lambda", "import", "os", "system", "__class__", "\\", "\n", "#", "@", "%"] + PAYLOADS


def token_soup() -> st.SearchStrategy[str]:
    return st.lists(st.sampled_from(TOKENS), min_size=1, max_size=25).map("".join)


ANY_TEXT = st.one_of(st.text(max_size=120), token_soup(), st.sampled_from(PAYLOADS))


def _scene_data(R: object, mu: object, eps: object = 0.1) -> dict:
    return {"name": "p", "excitation": {"velocity": 1.0}, "perturbation": {"R": R, "eps": eps, "params": {"mu": mu}},
            "output": {"contacts": [16, 30], "methods": ["map"]}}


@pytest.fixture(autouse=True, scope="module")
def _no_sentinel():
    SENTINEL.unlink(missing_ok=True)
    _warm_up()
    yield
    assert not SENTINEL.exists(), "user text created a file"


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(ANY_TEXT, ANY_TEXT)
def test_arbitrary_text_never_runs_code(text: str, other: str) -> None:
    """As R, as a parameter value, as eps: either a perturbation or a one-line PerturbationError."""
    for R, params, eps in ((text, {"mu": 1.0}, 0.1), ("-mu*v", {"mu": text}, 0.1), ("-mu*v", {"mu": 1.0}, text),
                           (text, {"mu": other}, "0.1")):
        with trapped() as calls:
            try:
                pert = make_perturbation(R, eps, params)
            except PerturbationError as exc:
                assert len(str(exc).splitlines()) == 1 and str(exc)
            else:
                assert pert.R.free_symbols <= {U, V, I, MU}
                assert math.isfinite(pert.eps) and pert.eps >= 0
        assert calls == []
    assert not SENTINEL.exists()


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(ANY_TEXT, st.one_of(ANY_TEXT, st.floats(), st.integers(), st.booleans(), st.lists(st.floats(), max_size=3)))
def test_arbitrary_scene_values_never_run_code(text: str, value: object) -> None:
    """Inside a scene: a Scene or a one-line SceneError, nothing else."""
    from pulsemap.solvers.data.scene import SceneError, parse_scene

    with trapped() as calls:
        try:
            parse_scene(_scene_data(text, value), "prop.toml")
        except SceneError as exc:
            assert len(str(exc).splitlines()) == 1 and str(exc).startswith("prop.toml")
    assert calls == []
    assert not SENTINEL.exists()


# --------------------------------------------------------------------------- the grammar


POINT = {U: Fraction(3, 10), V: Fraction(-7, 10), I: Fraction(5), MU: Fraction(3, 2)}
FUNCS = {"sin": math.sin, "cos": math.cos, "exp": lambda x: math.exp(x) if x < 700 else math.inf,  # no OverflowError
         "tanh": math.tanh}


def _leaf():
    names = st.sampled_from([("u", 0.3), ("v", -0.7), ("i", 5.0), ("mu", 1.5)])
    numbers = st.integers(1, 99).map(lambda k: (f"{k / 10:g}", k / 10))
    return st.one_of(names, numbers)


def _extend(children):
    binary = st.tuples(children, st.sampled_from(["+", "-", "*"]), children).map(
        lambda t: (f"({t[0][0]}){t[1]}({t[2][0]})",
                   {"+": t[0][1] + t[2][1], "-": t[0][1] - t[2][1], "*": t[0][1] * t[2][1]}[t[1]]))
    divide = st.tuples(children, st.integers(1, 9)).map(lambda t: (f"({t[0][0]})/{t[1]}", t[0][1] / t[1]))
    power = st.tuples(children, st.sampled_from(["**", "^"]), st.integers(0, 3)).map(
        lambda t: (f"({t[0][0]}){t[1]}{t[2]}", t[0][1] ** t[2]))
    call = st.tuples(st.sampled_from(sorted(FUNCS)), children).map(
        lambda t: (f"{t[0]}({t[1][0]})", FUNCS[t[0]](t[1][1])))
    negate = children.map(lambda t: (f"-({t[0]})", -t[1]))
    return st.one_of(binary, divide, power, call, negate)


GRAMMAR = st.recursive(_leaf(), _extend, max_leaves=12)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(GRAMMAR)
def test_grammar_strings_parse_to_the_right_value(tree: tuple[str, float]) -> None:
    text, expected = tree
    if not math.isfinite(expected) or abs(expected) > 1e100:
        return
    with trapped() as calls:
        expr = parse_expression(text, ["mu"])
    assert calls == []
    value = float(expr.xreplace({s: sympy.Rational(f.numerator, f.denominator) for s, f in POINT.items()}).evalf(30))
    assert value == pytest.approx(expected, rel=1e-9, abs=1e-12)


# --------------------------------------------------------------------------- the derivation

S = Fraction(1, 4)  # s = (n - 1)/2 for n = 3/2
P = Fraction(5, 4)  # (n + 1)/2

MONOMIAL = st.tuples(st.integers(0, 3), st.integers(0, 3)).filter(lambda ab: ab != (0, 0))
POLY = st.dictionaries(MONOMIAL, st.integers(-5, 5).filter(bool), min_size=1, max_size=3)


def independent_terms(poly: dict[tuple[int, int], int], mu_on: tuple[int, int] | None):
    """Eq. 12 expanded by hand: c u^a v^b -> terms of g_i and g_{i+1} with their powers of A.

    g_i = R(d_i + d_ip1, v_i + v_ip1) - R(d_ip1, v_ip1): the binomial terms with k of d_i and m of
    v_i, except k = m = 0 (cancelled); g_{i+1} = R(d_ip1, v_ip1). Returns
    {(equation, exponents): (integer coefficient, has mu, power of A)}.
    """
    out = {}
    for (a, b), c in poly.items():
        mu = (a, b) == mu_on
        for k in range(a + 1):
            for m in range(b + 1):
                if k == 0 and m == 0:
                    continue
                out[(1, (k, a - k, m, b - m))] = (c * comb(a, k) * comb(b, m), mu, a + (1 + S) * b - S)
        out[(2, (a, b))] = (c, mu, a + (1 + S) * b - S)
    return out


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(POLY, st.booleans(), st.sampled_from([0.5, 2.0]))
def test_polynomial_perturbations_derive_and_match_an_independent_count(poly, with_mu, mu_value) -> None:
    from pulsemap.symbolic.derivation import derive_all, to_json

    mu_on = min(poly) if with_mu else None
    text = " + ".join(f"({c})*{'mu*' if (a, b) == mu_on else ''}u^{a}*v^{b}" for (a, b), c in sorted(poly.items()))
    pert = make_perturbation(text, 0.1, {"mu": mu_value} if with_mu else {})
    d = derive_all(pert, sympy_seconds=0)
    data = to_json(d)  # renders without error and is JSON-able
    assert data["monomials"] and data["map"]["P"] == "5/4"

    expected = independent_terms(poly, mu_on)
    got = {(t.equation, tuple(t.exponents)): t for t in d.expansion.terms}
    assert set(got) == set(expected)
    for key, (c, mu, power) in expected.items():
        term = got[key]
        assert Fraction(str(term.power)) == power, key
        assert sympy.expand(term.coefficient - c * (MU if mu else 1)) == 0, key

    # the map (Eq. 23) groups the terms by power of A ...
    for equation in (1, 2):
        powers = sorted({p for (e, _), (_, _, p) in expected.items() if e == equation})
        assert [Fraction(str(t.power)) for t in d.amap.power_terms(equation)] == powers
    # ... and the long-wave law (Eq. 30) has B = A^P to the powers (power of A)/P, each with
    # C_p = sum of coefficient x integral over the terms of that power (here, independently)
    sums: dict[Fraction, float] = {}
    for (e, exps), (c, mu, power) in expected.items():
        if e == 1:
            integral = d.constants[got[(e, exps)].integral]
            sums[power] = sums.get(power, 0.0) + c * (mu_value if mu else 1.0) * integral
    law = d.longwave
    assert law is not None, d.longwave_note
    nonzero = {p: c for p, c in sums.items() if abs(c) > 1e-12 * max(abs(x) for x in sums.values())}
    assert [Fraction(str(p)) for p in law.powers] == sorted(p / P for p in nonzero)
    for p, c in zip(law.powers, law.coefficients):
        assert c == pytest.approx(nonzero[Fraction(str(p)) * P], rel=1e-12)
