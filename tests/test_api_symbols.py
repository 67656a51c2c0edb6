"""The public equations hold the user's symbols: name-based subs, the user's own Symbol, lambdify and solve
work on every derived object (map, ODE, law, Eq. 41, balances), as in any sympy code."""

from __future__ import annotations

import numpy as np
import pytest
import sympy

import pulsemap

MODELS = ("energy", "momentum")


def _objects(d) -> dict:
    """Every sympy equation a derivation hands out, by where it comes from: (equation, its symbols by name)."""
    out = {f"map[{k}]": (eq, d.symbols) for k, eq in enumerate(d.map)}
    out.update({"ode": (d.ode, d.symbols), "law": (d.law, d.symbols), "Eq. 41": (d.stationary, d.symbols)})
    for model in MODELS:
        if model == "momentum" and "u" in d.symbols:
            continue  # a foundation term's impulse diverges: no momentum balance
        b = d.balance(model)
        out.update({f"{model} {key}": (eq, b.symbols) for key, eq in (("map", b.map), ("ode", b.ode), ("law", b.law))})
    return {key: pair for key, pair in out.items() if pair[0] is not None}


def _lambdify_matches_subs(expr: sympy.Expr) -> None:
    """lambdify in symbols the test makes itself (by name) gives what subs of the same numbers gives."""
    funcs = sorted(expr.atoms(sympy.core.function.AppliedUndef), key=str)
    names = sorted({s.name for s in expr.free_symbols})
    mine = sympy.symbols(names) if names else []
    point = {name: 0.5 + 0.1 * k for k, name in enumerate(names)}
    fvals = [0.7 + 0.1 * k for k in range(len(funcs))]
    f = sympy.lambdify([*funcs, *mine], expr, "numpy")
    got = f(*fvals, *[point[name] for name in names])
    expected = expr.subs(dict(zip(funcs, fvals))).subs({s: point[s.name] for s in mine})
    assert not expected.free_symbols, expected.free_symbols
    assert np.isfinite(got) and got == pytest.approx(complex(expected), rel=1e-12, abs=1e-300)


@pytest.mark.parametrize("R", ["-mu*v", "-(u - mu*(1 - u^2)*v)"])
def test_every_derived_object_takes_names_the_users_symbol_lambdify_and_solve(R):
    d = pulsemap.derive(R)
    mu = sympy.Symbol("mu")  # the user's own symbol, made after the derivation
    objects = _objects(d)
    assert {"map[0]", "ode", "Eq. 41", "energy map", "energy ode"} <= set(objects)
    for key, (eq, symbols) in objects.items():
        assert mu in eq.free_symbols, key
        assert all(symbols[s.name] == s for s in eq.free_symbols), key
        by_name, by_symbol = eq.subs({"mu": 2}), eq.subs(mu, 2)
        assert by_name == by_symbol and by_name != eq and mu not in by_name.free_symbols, key
        _lambdify_matches_subs(eq.rhs if key.endswith(("law", "ode")) else eq.rhs - eq.lhs)
        if "law" in key:  # the contact where the power law's amplitude reaches zero
            base = eq.rhs.base
            (i_end,) = sympy.solve(base, sympy.Symbol("i"))
            assert sympy.Symbol("i") not in i_end.free_symbols and mu in i_end.free_symbols
            assert sympy.simplify(base.subs("i", i_end)) == 0, key
            continue
        solutions = sympy.solve(eq, mu)
        assert solutions, key
        for sol in solutions:
            assert mu not in sol.free_symbols
            assert sympy.simplify((eq.lhs - eq.rhs).subs(mu, sol)) == 0, key


def test_the_laws_are_checked_where_they_exist():
    """The power laws of -mu*v (Eq. 30, energy and momentum balance) are among the objects checked above."""
    objects = _objects(pulsemap.derive("-mu*v"))
    assert {"law", "energy law", "momentum law"} <= set(objects)


def test_values_and_symbols_agree_with_the_numbers_of_a_valued_derivation():
    """d.values keys are d.symbols' objects; substituted with mu = 2 the free law is the law of derive(mu=2)."""
    free, fixed = pulsemap.derive("-mu*v"), pulsemap.derive("-mu*v", mu=2)
    assert set(free.values) <= set(free.symbols.values())
    assert set(free.symbols) >= {"mu", "epsilon", "A_0", "i_0", "i", "f1", "f3", "g1_0010"}
    point = {"A_0": 0.8, "i_0": 10, "i": 25}
    a = free.law.rhs.subs(free.values).subs({"mu": 2, **point})
    b = fixed.law.rhs.subs(fixed.values).subs(point)
    assert float(a) == pytest.approx(float(b), rel=1e-14) and abs(float(a) - 0.8) > 1e-3


def test_a_sympy_R_keeps_the_users_own_symbol_objects():
    """R given as sympy with the user's positive mu: the equations hold that very object."""
    u, v = sympy.symbols("u v")
    mu = sympy.Symbol("mu", positive=True)
    d = pulsemap.derive(-(u - mu * (1 - u**2) * v))
    assert d.symbols["mu"] is mu and d.symbols["u"] is u
    for key, (eq, _) in _objects(d).items():
        assert mu in eq.free_symbols and sympy.Symbol("mu") not in eq.free_symbols, key
        assert mu not in eq.subs(mu, 3).free_symbols
    assert d.R == -(u - mu * (1 - u**2) * v)


def test_a_parameter_named_like_an_integral_stays_apart():
    """A parameter called f1 is not the profile integral f1: d.symbols['f1'] is the parameter."""
    d = pulsemap.derive("-f1*v")
    f1s = [s for s in d.law.free_symbols if s.name == "f1"]
    assert len(f1s) == 2 and d.symbols["f1"] == sympy.Symbol("f1")
    valued = [s for s in d.values if s.name == "f1"]
    assert len(valued) == 1 and valued[0] != sympy.Symbol("f1")
