"""Time-bounded sympy work is cached with its outcome, found or timed out (derive/sympy_cache.py)."""

from __future__ import annotations

import time

import pytest
import sympy

from pulsemap.symbolic import cache, sympy_cache
from pulsemap.symbolic.expression import symbol
from pulsemap.symbolic.longwave import B, integrate_reciprocal, reciprocal_integral


@pytest.fixture
def calls(monkeypatch, tmp_path):
    """Count the bounded (forked) computations actually run, in a fresh cache."""
    monkeypatch.setenv("PULSEMAP_CACHE_DIR", str(tmp_path))
    seen: list[float] = []
    real = sympy_cache.bounded

    def counting(func, args, seconds):
        seen.append(seconds)
        return real(func, args, seconds)

    monkeypatch.setattr(sympy_cache, "bounded", counting)
    return seen


def _slow(x):
    time.sleep(5)
    return x


def test_a_time_out_is_cached_and_a_larger_bound_tries_again(calls):
    x = sympy.Symbol("x")
    assert sympy_cache.bounded_cached("slow", "x", _slow, (x,), 0.2) is None
    assert sympy_cache.bounded_cached("slow", "x", _slow, (x,), 0.2) is None
    assert calls == [0.2]  # the second call did not wait again
    assert sympy_cache.bounded_cached("slow", "x", _slow, (x,), 0.3) is None
    assert calls == [0.2, 0.3]


def test_a_closed_form_is_cached_and_read_back_equal(calls):
    coeffs, powers = (-1.5, 0.25), (sympy.Integer(0), sympy.Integer(1))
    first = reciprocal_integral(coeffs, powers, 20.0)
    assert first is not None and not first.has(sympy.Integral)
    again = reciprocal_integral(coeffs, powers, 20.0)
    assert len(calls) == 1 and again == first
    # the cached antiderivative differentiates back to the integrand
    assert abs(float((sympy.diff(again, B) * (coeffs[0] + coeffs[1] * B)).subs(B, 3.0)) - 1) < 1e-12
    assert again == integrate_reciprocal(coeffs, powers, B)


@pytest.mark.parametrize("text", [
    "__import__('os').system('true')",
    "Symbol('x').__class__",
    "eval('1')",
    "Symbol(**{'name': 'x'})",
    "lambda: 1",
])
def test_srepr_reader_builds_only_sympy_classes(text):
    with pytest.raises(ValueError):
        sympy_cache.from_srepr(text)


def test_srepr_reader_round_trips_user_symbols_and_floats():
    e = symbol("mu") * sympy.Float("1.2345678901234567", 17) + sympy.RootSum(
        sympy.Poly(B**5 + B + 1), sympy.Lambda(B, sympy.log(B)))
    assert sympy_cache.from_srepr(sympy.srepr(e)) == e


def test_a_damaged_entry_is_computed_again(calls, capsys):
    x = sympy.Symbol("x")
    base = f"id|x|sympy {sympy.__version__}|found"
    cache.store(sympy_cache.NAMESPACE, base, {"srepr": "os.system('true')"})
    assert sympy_cache.bounded_cached("id", "x", sympy.expand, (x,), 5.0) == x
    assert "damaged" in capsys.readouterr().err and len(calls) == 1
