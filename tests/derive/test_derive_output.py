"""What `pulsemap derive` shows: the symbolic Eq. 30 in the user's symbols, a law constant that
cannot clash with a parameter and is defined where it appears, and each root's stability."""

from __future__ import annotations

import json

import pytest
import sympy

from pulsemap.symbolic.derivation import derive_all, to_json, to_latex, to_text
from pulsemap.symbolic.expression import UserSymbol
from pulsemap.symbolic.longwave import LAW_RATE
from pulsemap.symbolic.perturbation import make_perturbation


def _derive(R, params, **kw):
    return derive_all(make_perturbation(R, 0.1, params), **kw)


def test_symbolic_ode_keeps_the_users_symbols():
    d = _derive("-k*v - mu*u", {"mu": 3, "k": 0.5})
    ode = d.longwave.ode()
    users = {s.name for s in ode.free_symbols if isinstance(s, UserSymbol)}
    assert users == {"k", "mu"}
    # the numeric ODE is the symbolic one with the values and constants put in (independent substitution)
    by_name = {**d.constants, "k": 0.5, "mu": 3, "epsilon": 0.1}
    sym_rhs = ode.rhs.xreplace({s: sympy.Float(by_name[s.name], 20) for s in ode.rhs.free_symbols if s.name in by_name})
    num = d.longwave.ode(symbolic=False)
    B = sympy.Function("B")(sympy.Symbol("i", real=True))
    for b in (0.3, 0.7):
        assert float(sym_rhs.subs(B, b)) == pytest.approx(float(num.rhs.subs(B, b)), rel=1e-12)
    assert "3*g1_1000" not in to_text(d) and "g1_1000*mu" in to_text(d)


def test_the_law_rate_never_clashes_with_a_parameter_k():
    d = _derive("-k*v", {"k": 0.5})
    law = d.longwave.law
    assert LAW_RATE in law.free_symbols
    assert not any(isinstance(s, UserSymbol) for s in law.free_symbols)  # the user's k is not in A(i)
    text = to_text(d)
    law_line = next(line for line in text.splitlines() if line.strip().startswith("A(i) ="))
    assert "lambda_L" in law_line and "k" not in law_line.replace("lambda_L", "")
    definition = text.splitlines()[text.splitlines().index(law_line) + 1]
    assert definition.strip().startswith("where lambda_L = eps*C/(f1 - f3), C = -g1_0010*k")
    assert float(definition.rsplit("=", 1)[1]) == pytest.approx(d.longwave.rate(), rel=1e-11)
    data = to_json(d)["longwave"]
    assert data["rate_symbol"] == "lambda_L" and "lambda_L" in data["law"]


def test_a_parameter_named_like_the_rate_gets_another_printed_name():
    text = to_text(_derive("-lambda_L*v", {"lambda_L": 0.5}))
    assert "where lambda_L_ = eps*C/(f1 - f3), C = -g1_0010*lambda_L" in text


def test_latex_defines_every_symbol_of_the_law():
    tex = to_latex(_derive("-k*v", {"k": 0.5})).splitlines()
    law = next(k for k, line in enumerate(tex) if line.startswith("A(i) ="))
    assert r"\lambda_{L}" in tex[law] and " k" not in tex[law]
    assert tex[law + 1].startswith(r"\text{where } \lambda_{L} = ") and "k" in tex[law + 1]


def test_roots_of_eq41_carry_the_maps_multiplier():
    """Against the generated 1d map's Jacobian (solvers/models/stationary_shock, implicit function theorem)."""
    from pulsemap.solvers.models.codeload import map_module
    from pulsemap.solvers.models.stationary_shock import multiplier

    R, params = "-(u - mu*(1-u^2)*v)", {"mu": 3}
    d = _derive(R, params)
    data = to_json(d)["stationary"]["roots"]
    assert len(data) == 2
    mod = map_module(R, ("mu",), 1.5, "exact", "1d")
    for root in data:
        expected = multiplier(mod, root["A"], 0.1, {"mu": 3.0})
        assert root["multiplier_1d"] == pytest.approx(expected, rel=1e-9)
        assert root["stable"] == (abs(expected) < 1)
    assert [r["stable"] for r in data] == [False, True]  # the small root repels, the large one attracts
    text = to_text(d)
    assert "unstable" in text and ": stable" in text and "multiplier" in text
    json.dumps(data)
