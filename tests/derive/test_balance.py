"""Energy- and momentum-balance models: constants, laws, maps, runs and the ranking table."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
import sympy

from conftest import scene_toml, write_scene
from pulsemap.symbolic import codegen
from pulsemap.symbolic.balance import (
    BALANCE_METHOD,
    BalanceError,
    balance_constants,
    balance_expand,
    derive_balance,
    to_json,
    to_latex,
    to_text,
)
from pulsemap.symbolic.derivation import DerivationError, derive_model
from pulsemap.symbolic.expression import symbol
from pulsemap.symbolic.longwave import LAW_RATE, A0, I, I0
from pulsemap.symbolic.perturbation import make_perturbation
from pulsemap.symbolic.profile import exact_profile
from pulsemap.symbolic.sources import BALANCE_METHOD as SOURCES_BALANCE_METHOD
from pulsemap.solvers.models.balance_eval import evaluate_balance_law, iterate_balance_map
from pulsemap.solvers.models.codeload import balance_module
from pulsemap.solvers.studies.methods import MODELS
from pulsemap.solvers.studies.run import run_scene
from pulsemap.solvers.studies.run.report import to_csv
from pulsemap.solvers.data.scene import load_scene, with_overrides

VDP = "-(u - mu*(1 - u^2)*v)"
GENERATED = Path(codegen.PACKAGE_DIR)


def _bead_motion(n, tau, kmax=40):
    """X(tau) = sum_{k>=0} S(tau - k) and X'(tau) with numpy (independent of derive/balance.py)."""
    p = exact_profile(n)
    X = sum(p.S(tau - k) for k in range(kmax))
    dX = sum(p.dS(tau - k) for k in range(kmax))
    return p, X, dX


def test_sources_version_tracks_balance_version():
    assert SOURCES_BALANCE_METHOD == BALANCE_METHOD


# ----------------------------------------------------------------- exact statements
@pytest.mark.parametrize("n", [1.5, 2.5])
def test_damping_coefficients_follow_the_virial_theorem(n):
    """Averaged over a period, 2 K = sum x dV/dx = (n + 1) V for the contact potential delta^(n+1)/(n+1).

    So K_1/E_1 = (n+1)/(n+3) exactly, and for R = -mu v (W = -eps mu int x'^2 dt = -2 eps mu K_1 A^...)
    the energy law's rate is k = eps C/E_1 = -2 eps mu (n+1)/(n+3), independent of the profile.
    """
    eps, mu = 0.1, 1.7
    d = derive_balance(make_perturbation("-mu*v", eps, {"mu": mu}), "energy", n=n)
    c = d.constants
    assert c["K1"] / c["V1"] == pytest.approx((n + 1) / 2, rel=1e-10)
    assert c["K1"] / d.K == pytest.approx((n + 1) / (n + 3), rel=1e-10)
    assert d.law.kind == "power law"
    assert d.law.rate() == pytest.approx(-2 * eps * mu * (n + 1) / (n + 3), rel=1e-10)
    # momentum: J = -eps mu int x' dt = -eps mu (final displacement A D) and p_1 = D: k = -eps mu
    m = derive_balance(make_perturbation("-mu*v", eps, {"mu": mu}), "momentum", n=n)
    assert m.constants["p1"] == pytest.approx(m.constants["D"], rel=1e-10)
    assert m.law.rate() == pytest.approx(-eps * mu, rel=1e-10)


def test_foundation_work_is_the_spring_energy_at_the_final_displacement():
    """int X^a X' dtau = D^(a+1)/(a+1): the bead ends at x = A D (sum_m S(m + theta) = D)."""
    c = balance_constants(["D", "w_10", "w_30", "j_11", "j_21"])
    D = c["D"].value
    assert c["w_10"].value == pytest.approx(D**2 / 2, rel=1e-10)
    assert c["w_30"].value == pytest.approx(D**4 / 4, rel=1e-10)
    assert c["j_11"].value == pytest.approx(D**2 / 2, rel=1e-10)
    assert c["j_21"].value == pytest.approx(D**3 / 3, rel=1e-10)


def test_wave_energy_and_momentum_lattice_sum_equals_time_integral():
    """E_1, p_1 two ways: sum over beads at fixed time (numpy) vs int over the passage (mpmath)."""
    n = 1.5
    c = balance_constants(["K1", "V1", "p1"], n=n)
    E1 = c["K1"].value + c["V1"].value
    beads = np.arange(-30, 31)
    kinetic = []
    for tau in np.linspace(0.0, 1.0, 7):
        p, X, dX = _bead_motion(n, tau - beads)
        delta = np.maximum(p.S(tau - beads), 0.0)
        K = np.sum(dX**2) / 2
        E = K + np.sum(delta ** (n + 1)) / (n + 1)
        assert E == pytest.approx(E1, rel=1e-10)
        assert np.sum(dX) == pytest.approx(c["p1"].value, rel=1e-10)
        kinetic.append(K)
    # the split itself oscillates with the phase (only its average obeys the virial theorem)
    assert max(kinetic) - min(kinetic) > 1e-3 * E1


def test_wave_energy_and_momentum_against_an_unperturbed_dns():
    """Energy and momentum of the DNS front (beads within 8 of a peaked contact) = E_1 A^(n+1), p_1 A^(1+s)."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import minimize_scalar

    from pulsemap.solvers.chain.dns import initial_state, make_rhs

    n, beads = 1.5, 80
    c = balance_constants(["K1", "V1", "p1"], n=n)
    E1, p1 = c["K1"].value + c["V1"].value, c["p1"].value
    sol = solve_ivp(make_rhs(beads, n, None), (0, 90), initial_state(beads, 1.0), method="DOP853",
                    rtol=1e-11, atol=1e-13, dense_output=True)
    S0 = exact_profile(n).S0
    contact = 50

    def strain(t):
        x = sol.sol(t)[0::2]
        return x[contact - 1] - x[contact]

    ts = np.linspace(0, 90, 3000)
    k = int(np.argmax([strain(t) for t in ts]))
    peak = minimize_scalar(lambda t: -strain(t), bracket=(ts[k - 1], ts[k], ts[k + 1]), tol=1e-12)
    A = -peak.fun / S0
    y = sol.sol(peak.x)
    x, v = y[0::2], y[1::2]
    front = slice(contact - 9, contact + 8)
    d = np.maximum(x[:-1] - x[1:], 0.0)
    energy = 0.5 * np.sum(v[front] ** 2) + np.sum(d[front] ** (n + 1)) / (n + 1)
    assert energy == pytest.approx(E1 * A ** (n + 1), rel=1e-8)
    assert np.sum(v[front]) == pytest.approx(p1 * A ** (1 + (n - 1) / 2), rel=1e-7)
    assert energy < 0.5  # the impulse's energy v0^2/2: the front carries most, not all, of it


def test_exact_and_pade_profiles_agree_on_the_wave_constants():
    """Stated tolerance: the Pade form's fit error (about 4e-4 of S(0)) times a few."""
    names = ["K1", "V1", "p1"]
    ex = balance_constants(names, profile="exact")
    pa = balance_constants(names, profile="pade", dps=20)
    for name in names:
        assert pa[name].value == pytest.approx(ex[name].value, rel=2e-3), name
    assert ex["K1"].value != pa["K1"].value


# ------------------------------------------------------------------- laws in their ODE
def _residual(law, model_K, eps_value):
    """K d(A^Q)/di - eps sum C_p A^(Q p), with the law's k = eps C/K substituted."""
    A = law.law.xreplace({LAW_RATE: sympy.Float(law.rate(), 30)})
    B = A**law.Q
    rhs = eps_value * sum((c * B**p for c, p in zip(law.coefficients, law.powers)), sympy.Integer(0))
    return model_K * sympy.diff(B, I) - rhs, A


@pytest.mark.parametrize(
    "R, params, model, n",
    [
        ("-mu*v", {"mu": 1.0}, "energy", 1.5),
        ("alpha*u", {"alpha": -1.0}, "energy", 1.5),
        ("beta*u^3", {"beta": -1.0}, "energy", 1.5),
        ("-u^3", {}, "energy", 3),  # power 1 of B: exponential law
        ("-mu*v", {"mu": 1.0}, "momentum", 1.5),
        ("-c*u^2*v", {"c": 0.5}, "momentum", 1.5),
    ],
)
def test_each_law_substituted_back_into_its_ode(R, params, model, n):
    d = derive_balance(make_perturbation(R, 0.1, params), model, n=n)
    law = d.law
    assert law.law is not None and len(law.powers) == 1
    res, A = _residual(law, law.K, 0.1)
    subs = {A0: sympy.Rational(3, 5), I0: 2}
    for i in (2.5, 4, 7):
        value = res.xreplace(subs).xreplace({I: i})
        scale = abs(float(sympy.diff(A**law.Q, I).xreplace(subs).xreplace({I: i}))) * law.K
        assert abs(float(value)) < 1e-12 * max(scale, 1e-300), (i, value)
    assert A.xreplace({A0: sympy.Rational(3, 5), I0: 2, I: 2}) == sympy.Rational(3, 5)
    if n == 3:
        assert law.kind == "exponential"
    # symbolic check with sympy: the law solves its ODE identically in i, A_0, i_0 (and K, eps, C).
    # A power law is valid before its end, where its base b = A_0^(Q(1-p)) + (1-p) k (i - i_0) > 0:
    # write i through a positive symbol b, so that sympy may combine the fractional powers.
    k = LAW_RATE
    Ksym, eps_sym, C, b = sympy.symbols("K epsilon C b", positive=True)
    (p,) = law.powers
    A_law, di = law.law, 1
    if law.kind == "power law":
        A_law = A_law.xreplace({I: I0 + (b - A0 ** (law.Q * (1 - p))) / ((1 - p) * k)})
        di = (1 - p) * k  # d/di = (1-p) k d/db
    B = A_law**law.Q
    var = b if law.kind == "power law" else I
    ode = Ksym * di * sympy.diff(B, var) - eps_sym * C * B**p
    assert sympy.simplify(ode.xreplace({k: eps_sym * C / Ksym})) == 0


@pytest.mark.slow
@pytest.mark.parametrize("model", ["energy", "momentum"])
def test_implicit_law_of_several_powers_solves_its_ode(model):
    """n = 3, R = -v - u^2 v: two powers of B, integrated by sympy in closed form (i as a function of A)."""
    d = derive_balance(make_perturbation("-v - u^2*v", 0.1, {}), model, n=3, sympy_seconds=20)
    law = d.law
    assert len(law.powers) == 2 and law.kind == "implicit"
    A = sympy.Symbol("A", positive=True)
    didA = sympy.diff(law.implicit, A)  # the ODE: di/dA = K Q A^(Q-1) / (eps sum C_p A^(Q p))
    for a in (0.3, 0.6, 0.9):
        expected = law.K * float(law.Q) * a ** (float(law.Q) - 1) / (law.eps * law._rhs(a ** float(law.Q)))
        assert float(didA.xreplace({A: a, A0: 0.5})) == pytest.approx(expected, rel=1e-10)
    assert float(law.implicit.xreplace({A: 0.5, A0: 0.5, I0: 3})) == pytest.approx(3, abs=1e-12)


# ------------------------------------------------------------------ map against numerics
def _direct_map(R_func, seed_A, steps, eps, n=1.5, model="energy"):
    """The balance map evaluated directly: numpy quadrature of the work/impulse and of E_1, p_1."""
    s = (n - 1) / 2
    tau = np.linspace(-8, 8, 32001)
    p, X, dX = _bead_motion(n, tau)
    trap = lambda y: float(np.sum((y[1:] + y[:-1]) * np.diff(tau)) / 2)  # noqa: E731
    E1 = trap(dX**2 / 2) + trap(np.maximum(p.S(tau), 0) ** (n + 1) / (n + 1))
    p1 = trap(dX)
    K, Q = (E1, n + 1) if model == "energy" else (p1, 1 + s)
    out, a = [], seed_A
    for i in range(steps):
        u, v = a * X, a ** (1 + s) * dX
        f = R_func(u, v, i) * (v if model == "energy" else 1.0)
        rate = eps * trap(f) / a**s
        base = a**Q + rate / K
        if base <= 0:
            break
        a = base ** (1 / Q)
        out.append(a)
    return np.array(out)


@pytest.mark.parametrize(
    "R, params, model, f",
    [
        (VDP, {"mu": 3.0}, "energy", lambda u, v, i: -(u - 3.0 * (1 - u**2) * v)),
        ("-mu*v", {"mu": 1.0}, "momentum", lambda u, v, i: -1.0 * v),
        ("beta*u^3", {"beta": -1.0}, "energy", lambda u, v, i: -(u**3)),
    ],
)
def test_balance_map_equals_direct_numeric_evaluation(R, params, model, f):
    mod = balance_module(R, list(params), 1.5, "exact", model)
    run = iterate_balance_map(mod, 0.5, 15, 45, 0.1, params)
    direct = _direct_map(f, 0.5, 30, 0.1, model=model)
    got = np.array([a for a in run.A if a is not None])
    assert len(got) == len(direct) > 5
    assert got == pytest.approx(direct, rel=1e-8)


def test_site_dependent_balance_map_uses_each_beads_value():
    mod = balance_module("-k*u", ["k"], 1.5, "exact", "energy", ("k",))
    assert mod.PARAMS == ("k",) and mod.ARGS == (("k", 0),) and mod.UNIFORM is False
    k = np.linspace(0.0, 0.5, 140)
    run = iterate_balance_map(mod, 0.6, 15, 40, 0.3, {"k": k})
    direct = _direct_map(lambda u, v, i: -k[15 + i] * u, 0.6, 25, 0.3)  # step i: bead 16 + i
    got = np.array([a for a in run.A if a is not None])
    assert got == pytest.approx(direct[: len(got)], rel=1e-8) and len(got) == len(direct)
    with pytest.raises(ValueError, match="uniform"):
        evaluate_balance_law(mod, 0.6, 15.0, [16, 17], 0.3, {"k": k})


def test_law_is_the_continuum_limit_of_the_map():
    for R, params, model in ((VDP, {"mu": 1.0}, "energy"), ("-mu*v", {"mu": 1.0}, "momentum")):
        mod = balance_module(R, list(params), 1.5, "exact", model)
        contacts = np.arange(16, 60)
        gaps = []
        for eps in (0.01, 0.005):
            m = iterate_balance_map(mod, 0.5, 15, 59, eps, params)
            law = evaluate_balance_law(mod, 0.5, 15.0, contacts, eps, params)
            gaps.append(max(abs(a - b) / b for a, b in zip(m.A, law.A)))
        assert gaps[1] < 0.6 * gaps[0] and gaps[1] < 2e-3  # first order in eps


# ----------------------------------------------------------------------- refusals
def test_momentum_balance_refuses_a_term_without_v():
    for R, params in (("alpha*u", {"alpha": -1}), (VDP, {"mu": 3}), ("-k*u", {"k": [0.5] * 40})):
        pert = make_perturbation(R, 0.1, params)
        with pytest.raises(BalanceError, match="impulse int R dt diverges"):
            derive_balance(pert, "momentum")
    # no term without v: fine, and a constant force is refused for both models
    balance_expand(make_perturbation("-mu*(1 + u^2)*v", 0.1, {"mu": 1}).R, 1.5, "momentum")
    with pytest.raises(BalanceError, match="polynomial"):
        balance_expand(sympy.sin(symbol("u")), 1.5, "energy")
    with pytest.raises(DerivationError, match="map only"):
        derive_model(make_perturbation("-mu*v", 0.1, {"mu": 1}), "energy", fold="mu")


def test_run_refuses_momentum_for_a_foundation_and_solves_site_dependent_laws():
    res = run_scene(with_overrides(load_scene("fig6-eps0.1"), contacts=(16, 30)),
                    methods=["momentum-map", "energy-map", "energy-law"])
    assert res["peaks"]["momentum-map"] is None
    assert "diverges" in res["momentum-map"]["refused"]
    assert any(w.startswith("momentum-map refused") for w in res["warnings"])
    assert res["peaks"]["energy-map"][0] is not None and res["peaks"]["energy-law"][0] is not None
    site = run_scene(with_overrides(load_scene("fig13-seed1"), contacts=(16, 30)), methods=["energy-map", "energy-law"])
    # random per-bead stiffness: the law with piecewise-constant coefficients (derive/site_law.py)
    assert site["peaks"]["energy-law"][0] is not None and site["peaks"]["energy-map"][0] is not None
    assert site["energy-law"]["law_kind"] == "quadrature (site-dependent)"


# ------------------------------------------------------------------- runs and physics
def test_scene_file_lists_balance_models(tmp_path):
    text = scene_toml("damping-balance", eps=0.05, methods=("momentum-law", "energy-map", "dns"))
    path = write_scene(tmp_path, text, "s.toml")
    scene = load_scene(str(path))
    assert scene.methods == ("energy-map", "momentum-law", "dns")
    res = run_scene(scene)
    assert res["peaks"]["energy-map"][0] is not None and res["peaks"]["momentum-law"][0] is not None
    assert res["peaks"]["map"] is None and set(res["errors"]) == {"energy-map", "momentum-law"}
    bad = write_scene(tmp_path, text.replace('"energy-map"', '"energy-mapp"'), "bad.toml")
    with pytest.raises(ValueError, match="energy-map"):
        load_scene(str(bad))


def test_run_names_every_model_and_measures_errors():
    scene = with_overrides(load_scene("fig8-eps0.1"), contacts=(16, 40))
    res = run_scene(scene, methods=list(MODELS) + ["dns"])
    json.dumps(res)
    assert set(MODELS) == {"map", "longwave", "energy-map", "energy-law", "momentum-map", "momentum-law", "relaxed", "dressed-law"}
    for m in MODELS:
        assert len(res["peaks"][m]) == 25 and res["peaks"][m][0] is not None
        assert res["errors"][m]["compared"] + res["errors"][m]["missing"] == len(res["dns"]["live_contacts"])
    for m in ("energy-map", "energy-law", "momentum-map", "momentum-law"):
        assert res[m]["model"].startswith(m.replace("-map", "-balance map").replace("-law", "-balance law"))
        assert "balance_" in res[m]["generated"]
    d, e = np.array(res["peaks"]["dns"], float), np.array(res["peaks"]["energy-law"], float)
    a, b = res["errors"]["energy-law"]["live_range"]
    ok = slice(a - 16, b - 15)
    assert res["errors"]["energy-law"]["max_pct"] == pytest.approx(100 * np.max(np.abs(e[ok] - d[ok]) / d[ok]))
    header = to_csv(res).splitlines()[0]
    assert header.startswith("contact,dns,map,longwave,energy-map,energy-law,momentum-map,momentum-law,relaxed,dressed-law,dns_alive,")


def test_energy_law_converges_to_the_dns_as_eps_vanishes_for_damping():
    """Weak damping: the energy balance is exact at first order in eps, the momentum balance is not
    (the wake carries momentum): its decay rate is off by the factor (9/5 for n = 3/2) of the rates."""
    errs, mom = [], []
    for eps in (0.01, 0.003):
        scene = with_overrides(load_scene("fig8-eps0.1"), eps=eps, contacts=(16, 70))
        res = run_scene(scene, methods=["dns", "energy-law", "momentum-law", "map"])
        errs.append(res["errors"]["energy-law"]["max_pct"])
        d = np.array(res["peaks"]["dns"], float)
        m = np.array(res["peaks"]["momentum-law"], float)
        mom.append(math.log(m[-1] / m[0]) / math.log(d[-1] / d[0]))
        print(f"eps {eps}: energy-law max {errs[-1]:.2e} %, map {res['errors']['map']['max_pct']:.2e} %")
    assert errs[1] < 0.5 * errs[0] and errs[1] < 0.2
    assert mom[1] == pytest.approx(9 / 5, rel=0.1)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["fig6-eps0.1", "fig7-eps0.1", "vdp-mu1-v2.3"])
def test_energy_law_converges_to_the_dns_for_foundations_and_van_der_pol(name):
    """As eps -> 0 the energy balance's error vanishes (first-order theory), the paper map's does not."""
    errs, maps = [], []
    for eps in (0.01, 0.003):
        res = run_scene(with_overrides(load_scene(name), eps=eps, contacts=(16, 70)), methods=["dns", "energy-law", "map"])
        errs.append(res["errors"]["energy-law"]["max_pct"])
        maps.append(res["errors"]["map"]["max_pct"])
    print(f"{name}: energy-law max % {errs}, paper map {maps}")
    assert errs[1] < 0.5 * errs[0] and errs[1] < 1
    assert maps[1] > 2 * errs[1]


# ------------------------------------------------------------------- generated code
def test_committed_balance_modules_cover_the_builtin_scenes():
    names = {p.stem for p in GENERATED.glob("balance_*.py")}
    for scene in ("fig6-eps0.1", "fig7-eps0.1", "fig8-eps0.1", "vdp-mu3-v0.3", "fig13-seed1"):
        sc = load_scene(scene)
        pert = sc.perturbation
        src = codegen.balance_source(pert.text, pert.used_parameters, 1.5, "exact", "energy", pert.site_dependent)
        assert codegen.module_name(src) in names, scene


def test_generated_rate_equals_the_sympy_derivation():
    d = derive_balance(make_perturbation(VDP, 0.1, {"mu": 2.0}), "energy")
    mod = balance_module(VDP, ["mu"], 1.5, "exact", "energy")
    accuracy = max(d.errors[k] / abs(v) for k, v in d.constants.items())  # the module prints them to this
    for a in (0.2, 0.7, 1.3):
        direct = 0.1 * float(d.expansion.rate(sympy.Float(a), d.constants).xreplace({symbol("mu"): 2.0}))
        assert mod.balance_rate(a, 0.1, 2.0) == pytest.approx(direct, rel=3 * accuracy)
    assert mod.E1 == pytest.approx(d.K, rel=accuracy)


# ------------------------------------------------------------------------ rendering
def test_renderings_name_the_model():
    d = derive_balance(make_perturbation("-mu*v", 0.2, {"mu": 1}), "momentum", A0_value=0.5)
    data = to_json(d)
    json.dumps(data)
    assert data["model"] == "momentum" and data["wave"]["p1"] == pytest.approx(d.constants["p1"])
    assert data["law"]["singular_index"] == pytest.approx(d.law.singular_index(0.5)[0])
    assert to_text(d).startswith("Model: momentum balance")
    assert to_latex(d).startswith("% pulsemap derivation, model: momentum balance")
    e = to_json(derive_balance(make_perturbation("-mu*v", 0.2, {"mu": 1}), "energy"))
    assert e["model"] == "energy" and e["wave"]["kinetic_fraction"] == pytest.approx(5 / 9, rel=1e-10)


# ---------------------------------------------------------------------- ranking table
def test_table_row_ranks_every_model_and_names_the_winner():
    from pulsemap.solvers.studies.table import COLUMNS, markdown, scene_row

    row = scene_row("fig8-eps1")
    assert set(row["errors"]) == {c.key for c in COLUMNS}
    scored = {k: e["rms_pct"] for k, e in row["errors"].items() if e is not None}
    assert len(scored) == len(COLUMNS)  # damping: every model is defined
    assert row["winner"]["model"] == min(scored, key=scored.get)
    assert row["winner"]["rms_pct"] == min(scored.values()) <= row["winner"]["runner_up_rms_pct"]
    for e in row["errors"].values():  # a model that ended counts as 100 % at the contacts it missed
        assert e["unit"] == "percent" and (e["missing"] == 0 or e["max_pct"] == 100.0)
        assert e["rms_pct"] ** 2 * (e["compared"] + e["missing"]) >= 100.0 ** 2 * e["missing"] * (1 - 1e-12)
    assert any(e["missing"] for e in row["errors"].values())
    text = markdown([row])
    assert "**" + row["winner"]["model"] + "**" in text and text.count("\n| fig8-eps1 |") == 1


def test_table_appends_rows_and_skips_finished_scenes(tmp_path, monkeypatch):
    import pulsemap.solvers.studies.table as table_mod
    from pulsemap.solvers.data.records import encode_record

    calls = []

    def fake_row(name, progress=False, columns=table_mod.COLUMNS, eps=None, sets=(), scene=None):
        calls.append(name)
        scene = table_mod._scene(name, eps, sets)
        return {"scene": name, "key": table_mod.row_key(scene.as_dict(), columns), "R": "x", "eps": 0.1, "v0": 1.0,
                "live": 1, "errors": {}, "winner": {}}

    monkeypatch.setattr(table_mod, "scene_row", fake_row)
    rows_file = tmp_path / "rows.jsonl"
    names = ["fig8-eps1", "fig6-eps1", "fig7-eps1"]
    table_mod.table(names[:2], rows_file=rows_file, workers=1)
    assert calls == names[:2] and len(rows_file.read_text().splitlines()) == 2
    with open(rows_file, "a") as fh:  # an interrupted write of the next scene
        fh.write('{"scene": "fig7-eps1", "key": ')
    rows = table_mod.table(names, rows_file=rows_file, workers=1)
    assert calls == names and [r["scene"] for r in rows] == names
    # a row computed for another scene definition (stale key) is recomputed
    lines = rows_file.read_text().splitlines()
    stale = json.loads(lines[0])
    stale.pop("sha256")
    stale["key"] = "0" * 20
    rows_file.write_text(encode_record(stale) + "\n")  # a whole row, with its digest, of another definition
    table_mod.table(names[:1], rows_file=rows_file, workers=1)
    assert calls == names + names[:1]
    table_mod.table(names[:1], rows_file=rows_file, workers=1, fresh=True)
    assert calls == names + names[:1] * 2 and len(rows_file.read_text().splitlines()) == 1
    # rows at another eps have their own keys: computed once, kept next to the paper-eps rows
    table_mod.table(names[:1], rows_file=rows_file, workers=1, eps=0.01)
    table_mod.table(names[:1], rows_file=rows_file, workers=1, eps=0.01)
    table_mod.table(names[:1], rows_file=rows_file, workers=1)
    assert calls == names + names[:1] * 3 and len(rows_file.read_text().splitlines()) == 2
    with pytest.raises(ValueError, match="eps"):
        table_mod.table(names[:1], rows_file=rows_file, workers=1, eps=-1.0)


def test_cli_derive_model_and_refusal(tmp_path, capsys):
    from pulsemap.solvers.cli.main import main

    out = tmp_path / "d.json"
    assert main(["derive", "-mu*v", "--param", "mu=1", "--model", "energy", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert text.startswith("Model: energy balance")
    data = json.loads(out.read_text())
    assert data["model"] == "energy" and data["law"]["kind"] == "power law"
    assert main(["derive", "-mu*v", "--param", "mu=1", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["model"] == "map"
    capsys.readouterr()
    assert main(["derive", "alpha*u", "--param", "alpha=-1", "--model", "momentum"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("pulsemap: error: the momentum balance is undefined") and err.count("\n") == 1


def test_a_non_polynomial_r_is_sent_to_the_quadrature_energy_law():
    """derive's closed form needs a polynomial R; the message names what runs any R instead."""
    R = make_perturbation("-mu*sin(u)", 0.1, {"mu": 1.0})
    with pytest.raises(BalanceError, match="--model energy.*quadrature.*--methods energy-law.*Taylor-expand"):
        derive_model(R, "energy")
