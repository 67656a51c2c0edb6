"""Symbolic derivation: expansion (Eqs. 9-12), map (Eq. 23), long-wave law (Eq. 30), Eq. 41."""

import numpy as np
import pytest
import sympy
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pulsemap.symbolic.amplitude_map import A_I, A_NEXT, A_PREV, EPS, AmplitudeMap
from pulsemap.symbolic.derivation import derive_all, to_json, to_latex, to_text
from pulsemap.symbolic.expansion import D0, D1, W0, W1, ExpansionError, bead_symbol, expand
from pulsemap.symbolic.expression import parse_expression, symbol
from pulsemap.symbolic.integrals import F_NAMES, constants
from pulsemap.symbolic.sources import INTEGRALS_METHOD as METHOD
from pulsemap.symbolic.longwave import LAW_RATE, A0, I, I0, longwave_law
from pulsemap.symbolic.perturbation import make_perturbation
from pulsemap.symbolic.profile import exact_profile
from pulsemap.symbolic.stationary import positive_roots

u, v = symbol("u"), symbol("v")


def _simpson(y, h):
    return h / 3 * (y[0] + y[-1] + 4 * y[1:-1:2].sum() + 2 * y[2:-1:2].sum())


def _map_for(text, params, n=1.5, profile="exact", variant="paper"):
    R = parse_expression(text, params.keys())
    ex = expand(R, n)
    c = constants(list(F_NAMES) + list(ex.integrals()), n=n, profile=profile)
    vals = {k: x.value for k, x in c.items()}
    pv = {symbol(k): sympy.Rational(repr(float(x))) for k, x in params.items()}
    return ex, AmplitudeMap(ex.n, variant, ex, vals, pv)


# ----------------------------------------------------------------- expansion vs ansatz
polys = st.lists(
    st.tuples(st.integers(0, 3), st.integers(0, 2), st.integers(-3, 3)), min_size=1, max_size=4
)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(polys, st.sampled_from([0.4, 1.0, 2.3]))
def test_monomial_expansion_equals_direct_substitution_of_the_ansatz(spec, amp):
    """int_{-inf}^{T_i} g_i(ansatz) dt (direct) = sum coeff * A^power * g^(1) (expansion)."""
    R = sum((c * u**a * v**b for a, b, c in spec if a + b > 0), sympy.Integer(0))
    if R == 0:
        return
    n = 1.5
    s = (n - 1) / 2
    ex = expand(R, n)
    p = exact_profile(n)
    tau = np.linspace(-9.0, 0.0, 18001)
    h = tau[1] - tau[0]
    d0, d1 = amp * p.S(tau), amp * p.S(tau - 1)
    w0, w1 = amp ** (1 + s) * p.dS(tau), amp ** (1 + s) * p.dS(tau - 1)
    Rf = sympy.lambdify((u, v), R, "numpy")
    direct1 = _simpson(np.broadcast_to(Rf(d0 + d1, w0 + w1) - Rf(d1, w1), tau.shape), h) / amp**s
    direct2 = _simpson(np.broadcast_to(Rf(d1, w1), tau.shape), h) / amp**s
    c = constants(ex.integrals())
    via1 = sum(float(t.coefficient) * amp ** float(t.power) * c[t.integral].value for t in ex.equation_terms(1))
    via2 = sum(float(t.coefficient) * amp ** float(t.power) * c[t.integral].value for t in ex.equation_terms(2))
    scale = 1 + abs(direct1) + abs(direct2)
    assert via1 == pytest.approx(direct1, abs=1e-8 * scale)
    assert via2 == pytest.approx(direct2, abs=1e-8 * scale)


# ------------------------------------------------------------------- the paper's examples
def test_foundation_gives_eqs_25_26():
    ex = expand(parse_expression("alpha*u + beta*u^3", ["alpha", "beta"]), 1.5)
    al, be = symbol("alpha"), symbol("beta")
    eq25 = al * D0 + be * (D0**3 + 3 * D0**2 * D1 + 3 * D0 * D1**2)
    assert sympy.expand(ex.g1 - eq25) == 0
    assert sympy.expand(ex.g2 - (al * D1 + be * D1**3)) == 0
    powers = {t.integral: t.power for t in ex.terms}
    assert powers == {
        "g1_1000": sympy.Rational(3, 4), "g1_3000": sympy.Rational(11, 4), "g1_2100": sympy.Rational(11, 4),
        "g1_1200": sympy.Rational(11, 4), "g2_10": sympy.Rational(3, 4), "g2_30": sympy.Rational(11, 4),
    }


def test_damping_gives_eqs_34_35():
    ex = expand(parse_expression("-mu*v", ["mu"]), 1.5)
    mu = symbol("mu")
    assert sympy.expand(ex.g1 + mu * W0) == 0  # Eq. 34: -eps mu delta_i'
    assert [(t.integral, t.power, t.coefficient) for t in ex.terms] == [
        ("g1_0010", 1, -mu), ("g2_01", 1, -mu)]


def test_van_der_pol_gives_eqs_38_39_41_read_as_errata_6_7():
    ex, amap = _map_for("-(u - mu*(1 - u^2)*v)", {"mu": 3})
    mu = symbol("mu")
    eq38 = -(D0 - mu * W0 + mu * ((D0 + D1) ** 2 * (W0 + W1) - D1**2 * W1))
    assert sympy.expand(ex.g1 - eq38) == 0
    # R1 of Eq. 39 as the paper defines it, by an independent quadrature:
    p = exact_profile(1.5)
    tau = np.linspace(-9, 0, 18001)
    R1 = _simpson((p.S(tau) + p.S(tau - 1)) ** 2 * (p.dS(tau) + p.dS(tau - 1)) - p.S(tau - 1) ** 2 * p.dS(tau - 1), tau[1] - tau[0])
    terms = {t.power: t.value for t in amap.power_terms(1)}
    c = amap.constants
    assert terms[sympy.Rational(3, 4)] == pytest.approx(-c["g1_1000"], rel=1e-12)
    assert terms[1] == pytest.approx(3 * c["g1_0010"], rel=1e-12)
    assert terms[3] == pytest.approx(-3 * R1, rel=1e-8)
    # Eq. 39 second equation: g2_10 A^(3/4) - mu g2_01 A + mu R2 A^3 with the bracket sign of Eq. 38
    terms2 = {t.power: t.value for t in amap.power_terms(2)}
    assert terms2[1] == pytest.approx(3 * c["g2_01"], rel=1e-12)
    assert terms2[3] == pytest.approx(-3 * c["g2_21"], rel=1e-12)


def test_random_foundation_keeps_the_term_eq44_drops():
    """erratum 8, docs/errata.rst: g_i = -k_i delta_i + (k_{i+1} - k_i) delta_{i+1}."""
    R = parse_expression("-k*u", ["k"])
    ex = expand(R, 1.5, site_dependent=["k"])
    ki, kip1 = bead_symbol("k", 0), bead_symbol("k", 1)
    assert sympy.expand(ex.g1 - (-ki * D0 + (kip1 - ki) * D1)) == 0
    assert sympy.expand(ex.g2 + kip1 * D1) == 0
    assert "g1_0100" in ex.integrals()


# ------------------------------------------------------------------------ the laws
SINGLE_POWER = ["alpha*u", "beta*u^3", "-mu*v", "c*u*v", "c*u^2", "c*v^2", "c*u^2*v"]


@pytest.mark.parametrize("text", SINGLE_POWER)
@pytest.mark.parametrize("n", [1.5, 2.5])
def test_closed_form_law_solves_its_ode_exactly(text, n):
    name = [s for s in ("alpha", "beta", "mu", "c") if s in text][0]
    _, amap = _map_for(text, {name: -0.7}, n=n)
    law = longwave_law(amap, 0.1)
    assert law.kind in ("power law", "exponential")
    k = LAW_RATE
    (p,) = law.powers
    assert sympy.simplify(law.law.subs(I, I0) - A0) == 0
    if p == 1:
        Bi = law.law**law.P
        assert sympy.simplify(sympy.diff(Bi, I) - k * Bi) == 0
        return
    # On the law's domain the base X = A0^(P(1-p)) + (1-p) k (i - i0) is positive: write i(X).
    X = sympy.Symbol("X", positive=True)
    i_of_X = I0 + (X - A0 ** (law.P * (1 - p))) / ((1 - p) * k)
    Bx = sympy.powdenest((law.law**law.P).subs(I, i_of_X), force=True)
    dB_di = sympy.diff(Bx, X) * (1 - p) * k  # chain rule, dX/di = (1 - p) k
    assert sympy.simplify(dB_di - k * Bx**p) == 0
    # and a wrong power does not solve it (the check can fail)
    assert sympy.simplify(dB_di - k * Bx ** (p + sympy.Rational(1, 7))) != 0


def test_linear_foundation_law_is_not_the_printed_31b():
    """erratum 1, docs/errata.rst: the printed A = (A0^2 + 8/5 k' t)^(1/2) does not solve B' = k B^(3/5)."""
    _, amap = _map_for("alpha*u", {"alpha": -1})
    law = longwave_law(amap, 0.1)
    k = LAW_RATE
    printed = (A0**2 + sympy.Rational(8, 5) * k * (I - I0)) ** sympy.Rational(1, 2)
    Bp = printed ** sympy.Rational(5, 4)
    assert sympy.simplify(sympy.diff(Bp, I) - k * Bp ** sympy.Rational(3, 5)) != 0
    point = {A0: 0.8, k: -0.05, I0: 0, I: 3}
    assert abs(float(law.law.subs(point)) - float(printed.subs(point))) > 1e-3


def test_cubic_foundation_with_negative_beta_decays():
    """erratum 2, docs/errata.rst: with beta < 0 the amplitude must decay, not blow up."""
    _, amap = _map_for("beta*u^3", {"beta": -1})
    law = longwave_law(amap, 0.1)
    f = sympy.lambdify(I, law.numeric_law().subs({A0: 1, I0: 0}))
    vals = [f(x) for x in (0, 10, 100, 1000)]
    assert all(b < a for a, b in zip(vals, vals[1:]))
    index, what = law.singular_index(1.0, 0.0)
    assert index is None and "decays" in what


def test_damping_law_reaches_zero_at_reported_index():
    _, amap = _map_for("-mu*v", {"mu": 1})
    law = longwave_law(amap, 0.3)
    index, what = law.singular_index(0.8, 15.0)
    assert "extinction" in what
    f = sympy.lambdify(I, law.numeric_law().subs({A0: 0.8, I0: 15}))
    assert abs(f(index)) < 1e-12
    assert f(index - 1) > 0


def test_multi_power_singular_index_by_quadrature_matches_ode():
    """Eq. 31a by quadrature: integrate dB/di numerically until B hits zero."""
    _, amap = _map_for("a*u - c*v", {"a": -1, "c": 1})
    law = longwave_law(amap, 0.2, seconds=0.5)
    index, what = law.singular_index(1.0, 0.0)
    assert "extinction" in what
    # explicit Euler-free check: RK4 on dB/di = k(B) until B < 0
    rhs = lambda b: law.eps / law.f1_minus_f3 * law._rhs(max(b, 0.0))  # noqa: E731
    b, i, h = 1.0, 0.0, 1e-3
    while b > 0:
        k1 = rhs(b); k2 = rhs(b + h / 2 * k1); k3 = rhs(b + h / 2 * k2); k4 = rhs(b + h * k3)  # noqa: E702
        b += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        i += h
    assert index == pytest.approx(i, abs=5e-3)


# ------------------------------------------------------------------------ Eq. 41
@pytest.mark.parametrize("profile", ["exact", "pade"])
def test_van_der_pol_saddle_node(profile):
    pert = make_perturbation("-(u - mu*(1 - u^2)*v)", 0.1, {"mu": 3})
    d = derive_all(pert, profile=profile, fold="mu")
    st_ = d.stationary
    assert len(st_.roots) == 2
    f = st_.fold
    assert f.kind == "minimum" and 1.0 < f.value < 2.0
    # at the fold: Phi = 0 and dPhi/dA = 0, checked on the sympy equation directly
    phi = st_.equation
    vals = {sympy.Symbol(k, real=True): v for k, v in d.constants.items()}
    phi_num = phi.xreplace(vals).xreplace({symbol("mu"): f.value})
    a = sympy.Symbol("A", positive=True)
    assert abs(float(phi_num.subs(a, f.A))) < 1e-9
    assert abs(float(sympy.diff(phi_num, a).subs(a, f.A))) < 1e-8
    # two roots just above the fold, none just below
    for mu, count in ((f.value * 1.01, 2), (f.value * 0.99, 0)):
        terms = [(t.power, float(t.coefficient.xreplace(vals).xreplace({symbol("mu"): mu}))) for t in d.amap.power_terms(1, numeric=False)]
        assert len(positive_roots(terms)) == count
    print(f"VdP saddle-node ({profile}): mu* = {f.value:.6f}, A* = {f.A:.6f}, peak {f.peak:.6f} (paper: 1.5)")


def test_stationary_roots_solve_eq41():
    pert = make_perturbation("-(u - mu*(1 - u^2)*v)", 0.1, {"mu": 3})
    d = derive_all(pert)
    a = sympy.Symbol("A", positive=True)
    for r in d.stationary.roots:
        assert abs(float(d.stationary.numeric.subs(a, r))) < 1e-12


def test_positive_roots_of_a_known_polynomial():
    # (A - 1)(A - 4) A^(1/2) = A^(5/2) - 5 A^(3/2) + 4 A^(1/2)
    terms = [(sympy.Rational(5, 2), 1.0), (sympy.Rational(3, 2), -5.0), (sympy.Rational(1, 2), 4.0)]
    assert positive_roots(terms) == pytest.approx((1.0, 4.0), rel=1e-12)


# ------------------------------------------------------------------------ map equations
@pytest.mark.parametrize("variant", ["paper", "corrected", "1d"])
def test_map_equations_numeric_equal_symbolic(variant):
    _, amap = _map_for("-mu*v + alpha*u", {"mu": 1, "alpha": -1}, variant=variant)
    sym = amap.equations()
    num = amap.equations(numeric=True)
    vals = {sympy.Symbol(k, real=True): v for k, v in amap.constants.items()}
    point = {A_PREV: 0.9, A_I: 0.8, A_NEXT: 0.75, EPS: 0.3}
    for e_s, e_n in zip(sym, num):
        lhs = float(e_s.xreplace(vals).xreplace(amap.params).xreplace(point))
        assert lhs == pytest.approx(float(e_n.xreplace(point)), rel=1e-12)


def test_json_text_latex_outputs():
    pert = make_perturbation("-(u - mu*(1 - u^2)*v)", 0.1, {"mu": 3})
    d = derive_all(pert, fold="mu", A0_value=0.5, i0=15)
    js = to_json(d)
    for key in ("S0", "f1", "f6", "monomials", "map", "longwave", "stationary"):
        assert key in js
    assert js["stationary"]["fold"]["param"] == "mu"
    assert len(js["stationary"]["roots"]) == 2
    assert js["stationary"]["roots"][1]["peak"] == pytest.approx(js["stationary"]["roots"][1]["A"] * js["S0"])
    import json
    json.dumps(js)
    assert "saddle-node" in to_text(d)
    assert r"\tag{41}" in to_latex(d)


def test_only_the_integrals_that_occur_are_computed():
    ex = expand(parse_expression("-mu*v", ["mu"]), 1.5)
    assert set(ex.integrals()) == {"g1_0010", "g2_01"}


@pytest.mark.parametrize(
    "text, match",
    [("sin(u)", "not a polynomial"), ("u + 1", "R\\(0, 0\\)"), ("exp(v) - 1", "not a polynomial")],
)
def test_non_polynomial_or_offset_r_is_refused(text, match):
    with pytest.raises(ExpansionError, match=match):
        expand(parse_expression(text), 1.5)


@pytest.mark.parametrize("model", ["map", "energy", "momentum"])
def test_zero_perturbation_gives_a_constant_law(model, capsys):
    """R = 0*u: no term forces the wave, so every model's law is A = A_0 (text and JSON, no crash)."""
    import json

    from pulsemap.solvers.cli.main import main

    assert main(["derive", "0*u", "--model", model, "--json", "-"]) == 0
    captured = capsys.readouterr()
    assert "A constant" in captured.err  # with --json -, the text goes to stderr and stdout is the JSON
    data = json.loads(captured.out)
    law = data.get("law") or data.get("longwave")
    assert law["kind"] == "constant" and law["law"] == "A_0"


@pytest.mark.parametrize("R, A0", [("-mu*v + u^7", 1e12), ("-mu*v + u^7", 1e-12), ("-mu*v", 1e12), ("-mu*v + v^9", 1e-12)])
def test_singular_index_at_the_ends_of_the_A0_range_is_finite_or_none(R, A0):
    """B = A0^P and B^p are taken in mpmath: no OverflowError, no 'stationary' from an underflow."""
    d = derive_all(make_perturbation(R, 0.1, {"mu": 1.0}), A0_value=A0, sympy_seconds=0)
    index, what = d.longwave.singular_index(A0)
    assert index is None or np.isfinite(index)
    assert "stationary amplitude" not in what or len(d.longwave.powers) > 1 and d.stationary.roots
    assert "nan" not in to_text(d) and "inf " not in to_text(d)


@pytest.mark.parametrize("kw, needle", [({"A0_value": float("nan")}, "A0 = nan"), ({"A0_value": 0.0}, "A0 = 0"),
                                        ({"i0": float("inf")}, "i0 = inf"), ({"sympy_seconds": -1}, "sympy_seconds = -1")])
def test_law_options_out_of_range_are_refused(kw, needle):
    from pulsemap.symbolic.balance import BalanceError, derive_balance
    from pulsemap.symbolic.derivation import DerivationError

    pert = make_perturbation("-mu*v", 0.1, {"mu": 1.0})
    with pytest.raises(DerivationError, match=needle.replace("(", r"\(")):
        derive_all(pert, **kw)
    with pytest.raises(BalanceError, match=needle):
        derive_balance(pert, "energy", **kw)


def test_max_seconds_stops_a_long_derivation_and_the_next_run_resumes(tmp_path, monkeypatch):
    """derive --max-seconds: DeriveTimeout naming where it stopped; the integrals done stay cached."""
    from pulsemap.symbolic import cache
    from pulsemap.symbolic.budget import DeriveTimeout

    import time

    from pulsemap.symbolic import integrals

    monkeypatch.setenv("PULSEMAP_CACHE_DIR", str(tmp_path))
    compute = integrals._compute_bounded
    monkeypatch.setattr(integrals, "_compute_bounded", lambda *a: (time.sleep(0.1), compute(*a))[1])  # >= 10 s in all
    pert = make_perturbation("u^9*v^9", 0.1)
    lines = []
    with pytest.raises(DeriveTimeout, match=r"max_seconds = 2\).*integrals.*of 107 done.*resumes"):
        derive_all(pert, sympy_seconds=0, max_seconds=2, progress=lines.append)
    assert lines and lines[0].startswith("derive: integrals not yet cached (one quadrature each) ")
    assert lines[-1].endswith(" s") and "/107, " in lines[-1]
    table = cache.load("integrals", f"v{METHOD}|exact|n=1.5|dps=16")
    assert table and 0 < len(table) < 107  # what was computed before the stop is kept
    monkeypatch.setattr(integrals, "_compute_bounded", compute)
    d = derive_all(pert, sympy_seconds=0)  # resumes: only the rest is computed
    assert len(d.expansion.terms) == 100 and d.stationary is not None


@pytest.mark.parametrize("bad", [0, -1, float("nan"), float("inf"), "10", True])
def test_max_seconds_out_of_range_is_refused(bad):
    from pulsemap.symbolic.derivation import DerivationError

    with pytest.raises(DerivationError, match="max_seconds"):
        derive_all(make_perturbation("-mu*v", 0.1, {"mu": 1}), max_seconds=bad)


def test_monomial_text_is_what_sympy_prints():
    ex = expand(parse_expression("(u+v+1)^4-1 + u^2*v^3", []), 1.5)
    assert len(ex.terms) > 30
    assert all(t.monomial_text == str(t.monomial) for t in ex.terms)
