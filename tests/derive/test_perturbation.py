"""Tests for pulsemap.symbolic.perturbation: parameter forms, per-bead values and validation messages."""

from __future__ import annotations

import numpy as np
import pytest
import sympy

from pulsemap.symbolic.expression import symbol
from pulsemap.symbolic.perturbation import (
    IndexExpression,
    ParamMap,
    Perturbation,
    PerturbationError,
    RandomDraw,
    make_perturbation,
    parse_cli_param,
    parse_param_value,
)

u, v, i = symbol("u"), symbol("v"), symbol("i")
mu, k = symbol("mu"), symbol("k")


# --------------------------------------------------------------------------- construction


def test_damping_scene_perturbation() -> None:
    p = make_perturbation("-mu*v", 0.3, {"mu": 1.0})
    assert p.R == -mu * v
    assert p.text == "-mu*v"
    assert p.eps == 0.3
    assert dict(p.params) == {"mu": 1.0}
    assert p.is_uniform
    assert p.scalar_params() == {mu: sympy.Integer(1)}
    assert p.used_parameters == ("mu",)


def test_perturbation_is_hashable_and_comparable() -> None:
    a = make_perturbation("-mu*v", 0.3, {"mu": 1, "k": [1, 2]})
    b = make_perturbation("-mu*v", 0.3, {"k": (1.0, 2.0), "mu": 1.0})
    assert a == b and hash(a) == hash(b)
    assert isinstance(a.params, ParamMap)
    assert a.params["k"] == (1.0, 2.0)
    assert {a: 1}[b] == 1
    with pytest.raises(AttributeError):
        a.eps = 1.0  # type: ignore[misc]


def test_scalar_params_are_exact_decimals() -> None:
    p = make_perturbation("-mu*v - k*u^3", 0.1, {"mu": 0.1, "k": "1/4"})
    values = p.scalar_params()
    assert values[mu] == sympy.Rational(1, 10)
    assert values[k] == sympy.Rational(1, 4)
    assert all(isinstance(x, sympy.Rational) for x in values.values())


def test_sympy_input_is_normalised_to_real_symbols() -> None:
    raw = -sympy.Symbol("mu") * sympy.Symbol("v") + sympy.Symbol("u") ** 3
    p = make_perturbation(raw, 0.2, {"mu": 2})
    assert p.R == -mu * v + u**3
    assert all(s.is_real for s in p.R.free_symbols)
    assert p.text == str(p.R)


@pytest.mark.parametrize(
    ("R", "params", "fragment"),
    [
        (sympy.Symbol("x") * sympy.Symbol("u"), {}, "unknown symbol 'x'"),
        (sympy.Symbol("eps") * sympy.Symbol("u"), {}, "'eps' must not appear"),
        (sympy.Function("f")(sympy.Symbol("u")), {}, "undefined function f(u)"),
        (sympy.Symbol("m") * sympy.Symbol("v"), {"mu": 1}, "did you mean 'mu'"),
        (sympy.I * sympy.Symbol("u"), {}, "complex"),
    ],
)
def test_sympy_input_is_checked(R: sympy.Expr, params: dict, fragment: str) -> None:
    with pytest.raises(PerturbationError, match=fragment.replace("(", r"\(").replace(")", r"\)")):
        make_perturbation(R, 0.1, params)


def test_is_uniform() -> None:
    assert make_perturbation("-mu*v", 0.1, {"mu": 1}).is_uniform
    assert make_perturbation("-u^3", 0.1, {}).is_uniform
    assert not make_perturbation("-i*v/100", 0.1, {}).is_uniform
    assert not make_perturbation("-mu*v", 0.1, {"mu": [1, 2, 3]}).is_uniform
    assert not make_perturbation("-mu*v", 0.1, {"mu": {"uniform": [0, 1], "seed": 3}}).is_uniform
    assert not make_perturbation("-mu*v", 0.1, {"mu": "1 + 0.01*i"}).is_uniform
    # a constant string is a scalar, not an index expression
    assert make_perturbation("-mu*v", 0.1, {"mu": "2/5"}).is_uniform
    # unused non-scalar parameters do not make R non-uniform
    assert make_perturbation("-mu*v", 0.1, {"mu": 1, "g": [1, 2]}).is_uniform


def test_scalar_params_refuses_non_uniform() -> None:
    with pytest.raises(PerturbationError, match="not uniform.*'mu' is a per-bead list of 3 values"):
        make_perturbation("-mu*v", 0.1, {"mu": [1, 2, 3]}).scalar_params()
    with pytest.raises(PerturbationError, match="R depends on i"):
        make_perturbation("-i*v", 0.1, {}).scalar_params()


# --------------------------------------------------------------------------- bead values


def test_bead_values_scalar() -> None:
    values = make_perturbation("-mu*v", 0.1, {"mu": 0.5}).bead_values("mu", 4)
    assert values.dtype == np.float64 and values.shape == (4,)
    np.testing.assert_array_equal(values, [0.5, 0.5, 0.5, 0.5])


def test_bead_values_list() -> None:
    p = make_perturbation("-mu*v", 0.1, {"mu": [1, 2.5, 3]})
    np.testing.assert_array_equal(p.bead_values("mu", 3), [1.0, 2.5, 3.0])
    with pytest.raises(PerturbationError, match="'mu' has 3 per-bead values but the chain has 140 beads"):
        p.bead_values("mu", 140)


def test_bead_values_random_draw_reproducible() -> None:
    draw = {"uniform": [0.5, 2.0], "seed": 7}
    a = make_perturbation("-mu*v", 0.1, {"mu": draw}).bead_values("mu", 50)
    b = make_perturbation("-mu*v", 0.1, {"mu": dict(draw)}).bead_values("mu", 50)
    c = make_perturbation("-mu*v", 0.1, {"mu": {"uniform": [0.5, 2.0], "seed": 8}}).bead_values("mu", 50)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    assert a.shape == (50,) and a.dtype == np.float64
    assert np.all((a >= 0.5) & (a < 2.0))
    np.testing.assert_array_equal(a, np.random.default_rng(7).uniform(0.5, 2.0, size=50))


def test_bead_values_index_expression() -> None:
    p = make_perturbation("-k*u^3", 0.1, {"k": "1 + 0.01*i"})
    assert isinstance(p.params["k"], IndexExpression)
    assert p.params["k"].expr == 1 + sympy.Rational(1, 100) * i
    np.testing.assert_allclose(p.bead_values("k", 3), [1.01, 1.02, 1.03], rtol=0, atol=1e-15)
    q = make_perturbation("-k*u", 0.1, {"k": "exp(-i/10)*abs(sin(i))"})
    n = np.arange(1, 6)
    np.testing.assert_allclose(q.bead_values("k", 5), np.exp(-n / 10) * np.abs(np.sin(n)), rtol=1e-14)


def test_bead_values_index_expression_not_finite() -> None:
    p = make_perturbation("-k*u", 0.1, {"k": "1/(i-2)"})
    assert p.bead_values("k", 1)[0] == -1.0
    with pytest.raises(PerturbationError, match="not finite.*bead 2"):
        p.bead_values("k", 3)
    with pytest.raises(PerturbationError, match="bead 1"):
        make_perturbation("-k*u", 0.1, {"k": "sqrt(-i)"}).bead_values("k", 2)


def test_bead_values_unknown_name_and_bad_beads() -> None:
    p = make_perturbation("-mu*v", 0.1, {"mu": 1})
    with pytest.raises(PerturbationError, match="did you mean 'mu'"):
        p.bead_values("mu2", 3)
    for beads in (0, -1, 2.5, True):
        with pytest.raises(PerturbationError, match="beads must be a positive integer"):
            p.bead_values("mu", beads)  # type: ignore[arg-type]


# --------------------------------------------------------------------------- value parsing


def test_parse_param_value_forms() -> None:
    assert parse_param_value("mu", 2) == 2.0 and isinstance(parse_param_value("mu", 2), float)
    assert parse_param_value("mu", np.float32(0.5)) == 0.5
    assert parse_param_value("mu", [1, 2]) == (1.0, 2.0)
    assert parse_param_value("mu", np.array([1.0, 2.0])) == (1.0, 2.0)
    assert parse_param_value("mu", {"uniform": [0, 1], "seed": 7}) == RandomDraw(0.0, 1.0, 7)
    assert parse_param_value("mu", "0.25") == 0.25
    assert parse_param_value("mu", "1, 2, 3/2") == (1.0, 2.0, 1.5)
    value = parse_param_value("mu", "2*i")
    assert isinstance(value, IndexExpression) and value.expr == 2 * i and value.text == "2*i"


def test_parse_cli_param() -> None:
    assert parse_cli_param("mu=0.5") == ("mu", 0.5)
    assert parse_cli_param(" k = 1,2,3") == ("k", (1.0, 2.0, 3.0))
    name, value = parse_cli_param("g=1+0.01*i")
    assert name == "g" and isinstance(value, IndexExpression)
    assert value.expr == 1 + sympy.Rational(1, 100) * i
    with pytest.raises(PerturbationError, match="NAME=VALUE"):
        parse_cli_param("mu")
    with pytest.raises(PerturbationError, match="'mu' has no value"):
        parse_cli_param("mu=")
    with pytest.raises(PerturbationError, match="invalid parameter name 'eps'"):
        parse_cli_param("eps=0.1")
    with pytest.raises(PerturbationError, match="invalid parameter name"):
        parse_cli_param("2x=1")


BAD_VALUES = [
    # (name, raw value, message fragment)
    ("mu", None, "'mu' has no value"),
    ("mu", "", "'mu' has no value"),
    ("mu", True, "is a boolean"),
    ("mu", [1, False], "element 2 = False is not a number"),
    ("mu", float("nan"), "not finite"),
    ("mu", float("inf"), "not finite"),
    ("mu", [1.0, float("inf")], "element 2"),
    ("mu", "1e999", "not finite"),
    ("mu", "abc", "unknown symbol 'abc'"),
    ("mu", "u + 1", "unknown symbol 'u'"),
    ("mu", "1, i", "element 2"),
    ("mu", "1,,2", "stray ','"),
    ("mu", [], "empty list"),
    ("mu", [[1, 2]], "element 1"),
    ("mu", ["1", 2], "element 1 = '1' is not a number"),
    ("mu", np.ones((2, 2)), "flat list"),
    ("mu", object(), "unsupported type"),
    ("mu", {"uniform": [0, 1]}, "random draws need a seed for reproducibility: {uniform = [0, 1], seed = 7}"),
    ("mu", {"seed": 1}, "needs uniform = [low, high]"),
    ("mu", {"uniform": [1, 0], "seed": 1}, "low > high"),
    ("mu", {"unifrom": [0, 1], "seed": 1}, "unknown random-draw key 'unifrom': did you mean 'uniform'?"),
    ("mu", {"uniform": [0, 1], "sed": 1}, "did you mean 'seed'?"),
    ("mu", {"uniform": [0, 1, 2], "seed": 1}, "uniform must be [low, high]"),
    ("mu", {"uniform": [0, "x"], "seed": 1}, "uniform high"),
    ("mu", {"uniform": [0, 1], "seed": 1.5}, "seed must be a non-negative integer"),
    ("mu", {"uniform": [0, 1], "seed": -1}, "seed must be a non-negative integer"),
    ("mu", {"uniform": [0, 1], "seed": True}, "seed must be a non-negative integer"),
    ("mu", {"uniform": [0, float("nan")], "seed": 1}, "not finite"),
    ("u", 1.0, "invalid parameter name 'u'"),
    ("sin", 1.0, "function name"),
]


@pytest.mark.parametrize(("name", "raw", "fragment"), BAD_VALUES, ids=[type(b[1]).__name__ if type(b[1]) is object else repr(b[1])[:30] for b in BAD_VALUES])
def test_bad_param_values(name: str, raw: object, fragment: str) -> None:
    with pytest.raises(PerturbationError) as info:
        parse_param_value(name, raw)
    message = str(info.value)
    assert fragment in message, message
    assert len(message.splitlines()) == 1


# --------------------------------------------------------------------------- validation


@pytest.mark.parametrize(
    ("R", "eps", "params", "fragment"),
    [
        ("-mu*v", 0.1, {}, "unknown symbol 'mu' in \"-mu*v\": declare it as a parameter"),
        ("-mu*v", 0.1, {"mu0": 1}, "did you mean 'mu0'"),
        ("-gama*v", 0.1, {"gamma": 1}, "did you mean 'gamma'"),
        ("-mu*v", 0.1, {"mu": 1, "muu": 2}, "'muu' is not used in R = -mu*v but looks like a typo of 'mu'"),
        ("-mu*v", float("nan"), {"mu": 1}, "eps = nan is not finite"),
        ("-mu*v", float("inf"), {"mu": 1}, "eps = inf is not finite"),
        ("-mu*v", True, {"mu": 1}, "eps = True is a boolean"),
        ("-mu*v", "x", {"mu": 1}, "eps: unknown symbol 'x'"),
        ("-mu*v", None, {"mu": 1}, "eps = None is not a number"),
        ("-mu*v + 1", 0.1, {"mu": 1}, "R(0,0) = 1 is not zero: a constant force"),
        ("-mu*v + mu", 0.1, {"mu": 0.5}, "R(0,0) = 1/2 is not zero"),
        ("cos(u) - v", 0.1, {}, "R(0,0) = 1 is not zero"),
        ("-v + 0.01*i", 0.1, {}, "R(0,0) = i/100 is not zero"),
        ("1/u", 0.1, {}, "R(0,0) is undefined"),
        ("sin(u)/u", 0.1, {}, "R(0,0) is undefined"),
        ("log(u)", 0.1, {}, "R(0,0) is undefined"),
        ("-eps*v", 0.1, {}, "'eps' must not appear"),
        ("-mu*v", 0.1, {"eps": 1}, "invalid parameter name 'eps'"),
        ("-v/(mu-1)", 0.1, {"mu": 1}, "undefined with the given parameter values (mu=1)"),
        ("sin(1)*cos(2) - v", 0.1, {}, "R(0,0) = sin(1)*cos(2) (= -0.350175) is not zero"),
        ("-mu*v", 0.1, {"mu": {"uniform": [0, 1]}}, "need a seed"),
        ("u.real", 0.1, {}, "attribute access is not allowed"),
        (42, 0.1, {}, "R(0,0) = 42 is not zero"),
        ([1], 0.1, {}, "R must be a string or a sympy expression"),
    ],
)
def test_make_perturbation_errors(R: object, eps: object, params: dict, fragment: str) -> None:
    with pytest.raises(PerturbationError) as info:
        make_perturbation(R, eps, params)  # type: ignore[arg-type]
    message = str(info.value)
    assert fragment in message, message
    assert len(message.splitlines()) == 1


@pytest.mark.parametrize(
    ("R", "params"),
    [
        ("-mu*v", {"mu": 1}),
        ("-mu*v + mu - 1", {"mu": 1}),  # vanishes once the scalar value is substituted
        ("cos(u) - 1 - v", {}),
        ("sin(1)^2 + cos(1)^2 - 1 - v", {}),  # zero, though sympy does not simplify it itself
        ("abs(i) - i + u", {}),  # i is a positive bead index
        ("sign(i) - 1 - u^3", {}),
        ("-(u - mu*(1-u^2)*v)", {"mu": 0.2}),
        ("-k*u^3 - mu*abs(v)*v", {"k": [1, 2], "mu": {"uniform": [0, 1], "seed": 1}}),
        ("-mu*v", {"mu": 1, "gamma": 3}),  # unused but not a typo: fine
    ],
)
def test_make_perturbation_accepts(R: str, params: dict) -> None:
    p = make_perturbation(R, 0.1, params)
    assert isinstance(p, Perturbation)


def test_check_at_rest_with_per_bead_values() -> None:
    p = make_perturbation("k - 1 + u", 0.1, {"k": [1, 1, 2]})  # undecidable until beads are known
    np.testing.assert_array_equal(p.rest_force(3), [0.0, 0.0, 1.0])
    with pytest.raises(PerturbationError, match="R\\(0,0\\) = 1 is not zero at bead 3"):
        p.check_at_rest(3)
    make_perturbation("k*u", 0.1, {"k": [1, 1, 2]}).check_at_rest(3)


def test_unused_parameters_are_reported() -> None:
    p = make_perturbation("-mu*v", 0.1, {"mu": 1, "gamma": 3})
    assert p.unused_parameters == ("gamma",)
    assert set(p.scalar_params()) == {mu, symbol("gamma")}


def test_eps_accepts_numbers_and_numeric_strings() -> None:
    assert make_perturbation("-v", 0, {}).eps == 0.0
    assert make_perturbation("-v", "1e-3", {}).eps == 0.001
    assert make_perturbation("-v", np.float64(0.2), {}).eps == 0.2
    with pytest.raises(PerturbationError, match="eps = -0.2 must be >= 0"):  # the sign belongs in R
        make_perturbation("-v", np.float64(-0.2), {})


def test_values_at_one_position_is_the_bead_of_the_array_path() -> None:
    """values_at's one-position shortcut (a law's right-hand side) gives the array path's value,
    the draw is kept read-only, and bead_values still hands out a fresh writable copy."""
    pert = make_perturbation("-mu*v", 0.1, {"mu": {"uniform": [0.5, 2.0], "seed": 3}})
    positions = np.array([0.2, 1.0, 1.49, 1.5, 7.5, 17.3, 49.9, 60.0])
    many = pert.values_at("mu", positions)
    one = [float(pert.values_at("mu", [p])[0]) for p in positions]
    assert one == many.tolist()
    beads = pert.bead_values("mu", 61)
    beads[0] = -1.0  # the caller's copy: the kept draw is not touched
    assert pert.values_at("mu", [1.0])[0] == many[1] != -1.0
