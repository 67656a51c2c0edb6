"""The public API: pulsemap.derive, scene, run, scenes and what they return (solvers/api/)."""

from __future__ import annotations

import dataclasses
import json
import math
import subprocess
import sys

import numpy as np
import pytest
import sympy

import pulsemap
from pulsemap.solvers.data.scene import builtin_scenes

SMALL = {"output.contacts": (16, 30)}


@pytest.mark.process
def test_import_is_cheap_and_the_surface_is_small():
    """``import pulsemap`` loads neither sympy nor scipy nor numpy (a fresh interpreter)."""
    code = ("import sys, pulsemap; heavy = [m for m in ('sympy', 'scipy', 'numpy', 'mpmath') if m in sys.modules];"
            "print(heavy); print(sorted(pulsemap.__all__))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.splitlines()
    assert out[0] == "[]"
    assert out[1] == str(sorted(["Balance", "Derivation", "PulsemapError", "Result", "Scene", "__version__", "derive",
                                 "derive_contact", "dressed", "run",
                                 "scene", "scenes"]))
    for name in pulsemap.__all__:
        assert getattr(pulsemap, name) is not None


def test_the_namespace_holds_the_public_names_and_the_three_installed_folders_only():
    """dir(pulsemap) shows what a user may use (no ``annotations`` of a __future__ import)."""
    shown = {name for name in dir(pulsemap) if not name.startswith("_")}
    assert "annotations" not in shown and shown <= set(pulsemap.__all__) | {"solvers", "symbolic", "generated"}
    assert pulsemap.Balance is type(pulsemap.derive("-mu*v").balance())
    assert isinstance(pulsemap.scene("default"), pulsemap.Scene)


def test_derive_is_a_plain_function_and_the_symbolic_layer_has_its_own_name():
    import inspect
    import types

    import pulsemap.symbolic.profile as profile_module
    from pulsemap.solvers.api.derivation import derive

    assert isinstance(pulsemap.derive, types.FunctionType) and pulsemap.derive is derive
    assert pulsemap.symbolic.profile is profile_module
    assert "eps" in str(inspect.signature(pulsemap.derive))
    assert "Eq. 23" in (inspect.getdoc(pulsemap.derive) or "")


# --------------------------------------------------------------------------- derive


def _law_residual(d, Q=None) -> sympy.Expr:
    """The law A(i) put back into its ODE (B = A^Q; Q = (n+1)/2 for Eq. 30), written in the positive base
    w of the power law (i solved for w), so that sympy may combine the powers. The public symbols carry no
    assumptions: the user's way to add them (real symbols, epsilon and A_0 positive) is a substitution."""
    real = {s: sympy.Symbol(name, positive=True) if name in ("A_0", "epsilon") else sympy.Symbol(name, real=True)
            for name, s in d.symbols.items()}
    ode, law = d.ode.xreplace(real), d.law.xreplace(real)
    (B,) = ode.atoms(sympy.core.function.AppliedUndef)
    i = B.args[0]
    Q = (sympy.Rational(1.5) + 1) / 2 if Q is None else Q
    residual = (ode.lhs - ode.rhs).subs(B, law.rhs**Q).doit()
    w = sympy.Symbol("w", positive=True)
    (i_of_w,) = sympy.solve(sympy.Eq(law.rhs.base, w), i)
    return sympy.simplify(residual.subs(i, i_of_w))


@pytest.mark.parametrize("R", ["-mu*v", "-k*u", "-mu*u*v", "-mu*v^3"])
def test_symbolic_law_solves_its_long_wave_ode(R):
    """With every parameter left symbolic, the law (a sympy Eq) solves Eq. 30 exactly; a wrong law does not."""
    d = pulsemap.derive(R)
    assert d.law_kind == "power law" and isinstance(d.law, sympy.Eq) and isinstance(d.ode, sympy.Eq)
    assert set(d.free) <= {s.name for s in d.law.free_symbols} and d.free
    assert _law_residual(d) == 0
    wrong = dataclasses.replace(d, law=sympy.Eq(d.law.lhs, d.law.rhs.func(d.law.rhs.base * 2, d.law.rhs.exp)))
    assert _law_residual(wrong) != 0


@pytest.mark.parametrize("model, R, Q", [("energy", "-mu*v", sympy.Rational(5, 2)),
                                         ("energy", "-k*u", sympy.Rational(5, 2)),
                                         ("momentum", "-mu*v^3", sympy.Rational(5, 4))])
def test_balance_laws_are_sympy_and_solve_their_ode(model, R, Q):
    """The balance laws with the parameter free: sympy Eq objects, the law solves its ODE exactly, and with
    the parameter's value substituted it is the numeric law of derive(..., value)."""
    free = pulsemap.derive(R).balance(model)
    assert free.model == model and isinstance(free.map, sympy.Eq) and free.law_kind == "power law"
    name = R.split("*")[0].lstrip("-")
    par = next(s for s in free.law.free_symbols if s.name == name)
    assert _law_residual(free, Q) == 0
    fixed = pulsemap.derive(R, **{name: 0.7}).balance(model)
    a = float(free.law.rhs.subs(free.values).subs({par: 0.7, "A_0": 0.8, "i_0": 15.0, "i": 30.0}))
    internal = {s.name: s for s in fixed.details.law.numeric_law().free_symbols}
    b = float(fixed.details.law.numeric_law().subs({internal["A_0"]: 0.8, internal["i_0"]: 15.0, internal["i"]: 30.0}))
    assert a == pytest.approx(b, rel=1e-13) and abs(a - 0.8) > 1e-3
    latex = free._repr_latex_()
    assert latex.startswith("$$\\begin{align}") and "A(i) = " in latex and f"model: {model}" not in latex
    assert json.loads(json.dumps(fixed.to_dict()))["model"] == model and "Law, B = A^" in str(fixed)


def test_momentum_balance_of_a_foundation_is_refused():
    with pytest.raises(ValueError, match="momentum"):
        pulsemap.derive("-k*u", k=1).balance("momentum")
    with pytest.raises(ValueError, match="did you mean 'energy'"):
        pulsemap.derive("-k*u", k=1).balance("enrgy")


def test_symbolic_parameter_substituted_is_the_numeric_derivation():
    """pulsemap.derive("-mu*v") leaves mu free; mu = 2 substituted gives the numbers of derive(mu=2)."""
    free, fixed = pulsemap.derive("-mu*v"), pulsemap.derive("-mu*v", mu=2)
    mu = next(s for s in free.law.free_symbols if s.name == "mu")
    assert free.free == ("mu",) and fixed.free == () and fixed.params == {"mu": 2.0}
    numeric = fixed.details.longwave.numeric_law()  # A(i) with the rate lambda_L as a number
    internal = {s.name: s for s in numeric.free_symbols}
    for index in (15.0, 20.0, 40.0):
        a = float(free.law.rhs.subs(free.values).subs({mu: 2, "i": index, "A_0": 0.8, "i_0": 15.0}))
        b = float(numeric.subs({internal["i"]: index, internal["A_0"]: 0.8, internal["i_0"]: 15.0}))
        assert a == pytest.approx(b, rel=1e-13)
    assert [e.subs(mu, 2) for e in free.map] == [e.subs(mu, 2) for e in fixed.map]
    assert free.stationary == fixed.stationary and free.ode == fixed.ode
    with pytest.raises(ValueError, match="mu=VALUE"):
        free.rate
    with pytest.raises(ValueError, match="roots of Eq. 41 .* mu=VALUE"):
        free.roots
    assert "mu" in str(free) and "cannot be computed without a value for mu" in str(free)
    data = json.loads(json.dumps(free.to_dict()))
    assert data["free_parameters"] == ["mu"] and data["stationary"]["roots_need_values_for"] == ["mu"]
    assert data["longwave"]["rate_k"] is None and "mu" in data["longwave"]["law_numeric"]
    assert "free_parameters" not in fixed.to_dict()


def test_free_parameter_stationary_equation_has_the_numeric_roots():
    """Eq. 41 with mu free, mu = 3 substituted, vanishes at the roots derive(mu=3) reports."""
    free = pulsemap.derive("-(u - mu*(1 - u^2)*v)")
    fixed = pulsemap.derive("-(u - mu*(1 - u^2)*v)", mu=3)
    mu = next(s for s in free.stationary.free_symbols if s.name == "mu")
    (A,) = (s for s in free.stationary.free_symbols if s.name == "A")
    phi = sympy.lambdify(A, free.stationary.rhs.subs(free.values).subs(mu, 3))
    assert len(fixed.roots) == 2
    for root in fixed.roots:
        assert abs(phi(root)) < 1e-9 * abs(phi(2 * root))
    assert abs(phi(1.5 * fixed.roots[0])) > 1e-3 * abs(phi(2 * fixed.roots[0]))  # the check can fail


def test_sympy_expression_R_is_the_string_R():
    u, v, mu, i = sympy.symbols("u v mu i")
    for text, expr in (("-(u - mu*(1 - u^2)*v)", -(u - mu * (1 - u**2) * v)), ("-mu*v*(1 + 0*i)", -mu * v)):
        a, b = pulsemap.derive(text, mu=3), pulsemap.derive(expr, mu=3)
        assert (a.map, a.ode, a.law, a.stationary, a.roots) == (b.map, b.ode, b.law, b.stationary, b.roots)
        assert a.R == b.R and a.constants == b.constants
    free = pulsemap.derive(-mu * v)
    assert free.free == ("mu",) and free.law == pulsemap.derive("-mu*v").law


def test_free_parameter_next_to_per_bead_values():
    """A site-dependent R with a free parameter: the law's ODE keeps mu as a symbol, k(i) as a function."""
    d = pulsemap.derive("-k*u - mu*v", k=[0.5] * 40)
    assert d.free == ("mu",) and "mu" in {s.name for s in d.ode.free_symbols} and d.roots == ()
    assert d.ode.has(sympy.Function("k")) and "stationary" in d.notes
    assert "numerical integration cannot be computed without a value for mu" in str(d)
    assert "without a value" not in str(pulsemap.derive("-k*u - mu*v", k=[0.5] * 40, mu=1))


def test_van_der_pol_roots_solve_eq41():
    d = pulsemap.derive("-(u - mu*(1 - u^2)*v)", mu=3, eps=0.1)
    assert len(d.roots) == 2 and all(r > 0 for r in d.roots)
    (A,) = (s for s in d.stationary.free_symbols if s.name == "A")
    f = sympy.lambdify(A, d.stationary.rhs.subs(d.values))
    for root in d.roots:
        assert abs(f(root)) < 1e-9 * abs(f(2 * root))
    assert d.stationary_peaks == pytest.approx(tuple(r * d.S0 for r in d.roots))


@pytest.mark.parametrize("k", [[0.5] * 40, "0.5 + 0.01*i"], ids=["per-bead", "expression-of-i"])
def test_site_dependent_derivation(k):
    """A site-dependent R: the map keeps the (k_{i+1} - k_i) term, the law has coefficients C_p(i), no Eq. 41."""
    d = pulsemap.derive("-k*u", k=k)
    assert any("g1_0100" in str(eq) for eq in d.map)
    assert d.ode is not None and d.ode.has(sympy.Derivative) and d.rate is None
    assert d.stationary is None and d.roots == () and "stationary" in d.notes
    assert d.law_kind in ("power law", "exponential", "quadrature", "constant")
    assert json.loads(json.dumps(d.to_dict()))["expression"] == "-k*u"


def test_derivation_is_frozen_and_renders():
    d = pulsemap.derive("-mu*v", mu=1)
    with pytest.raises(dataclasses.FrozenInstanceError):
        d.eps = 0.2  # type: ignore[misc]
    data = json.loads(json.dumps(d.to_dict()))
    assert data["expression"] == "-mu*v" and data["variant"] == "paper" and "provenance" in data
    assert "Amplitude map" in str(d)
    latex = d._repr_latex_()
    assert latex.startswith("$$") and r"\tag{41}" in latex and r"\tag{23.1}" in latex and "A(i) = " in latex
    assert d.params == {"mu": 1.0} and d.profile == "exact" and d.n == 1.5


def test_derive_choices_reach_the_derivation():
    a = pulsemap.derive("-mu*v", mu=1, variant="1d", profile="pade")
    b = pulsemap.derive("-mu*v", params={"mu": 1})
    assert (a.variant, a.profile) == ("1d", "pade") and a.rate != b.rate and a.constants != b.constants
    assert a.map != b.map


@pytest.mark.parametrize("call, error, words", [
    (lambda: pulsemap.derive(1), TypeError, "R must be a string"),
    (lambda: pulsemap.derive("-mu*v + k"), ValueError, "R(0,0) = k is not zero"),
    (lambda: pulsemap.derive(sympy.Symbol("eps") * sympy.Symbol("v")), ValueError, "'eps' must not appear"),
    (lambda: pulsemap.derive("-mu*v", mu=1, profile="exat"), ValueError, "did you mean 'exact'"),
    (lambda: pulsemap.derive("-mu*v", mu=1, variant=3), TypeError, "variant must be a string"),
    (lambda: pulsemap.derive("-mu*v", mu=1, eps="x"), TypeError, "eps must be a number"),
    (lambda: pulsemap.derive("-mu*v", mu=1, eps=math.inf), ValueError, "eps = inf"),
    (lambda: pulsemap.derive("-mu*v", mu=1, n=0.5), ValueError, "exponent n"),
    (lambda: pulsemap.derive("-mu*v", mu=1, nu=2), ValueError, "'nu' given but not used"),
    (lambda: pulsemap.derive("-mu*v", mu=1, params={"mu": 2}), ValueError, "given twice"),
    (lambda: pulsemap.derive("-mu*v", params=[1]), TypeError, "params must be a mapping"),
])
def test_derive_bad_input(call, error, words):
    with pytest.raises(error, match=None) as info:
        call()
    assert words in str(info.value) and "\n" not in str(info.value)


# --------------------------------------------------------------------------- scenes


def test_scenes_lists_what_the_cli_lists_and_every_name_loads(capsys):
    from pulsemap.solvers.cli.main import main

    names = pulsemap.scenes()
    assert names[:len(builtin_scenes())] == builtin_scenes() and "fig8-eps0.3" in names and "damp-10" in names
    assert main(["scenes"]) == 0
    listed = [line.split()[0] for line in capsys.readouterr().out.splitlines() if line.startswith("  ")]
    assert listed == names
    assert all(pulsemap.scene(name).name for name in names)


def test_scene_overrides_dotted_and_short():
    a = pulsemap.scene("fig8-eps0.3", **{"perturbation.eps": 0.2, "output.contacts": (16, 40)})
    b = pulsemap.scene("fig8-eps0.3", eps=0.2, contacts=[16, 40])
    assert a == b and a.perturbation.eps == 0.2 and a.contacts == (16, 40)
    c = pulsemap.scene(a, mu=2, **{"dns.rtol": 1e-9})
    assert c.perturbation.params["mu"] == 2.0 and c.dns["rtol"] == 1e-9 and c.perturbation.eps == 0.2
    d = pulsemap.scene("default", R="-mu*v - nu*u*v", **{"perturbation.params.nu": 0.5})
    assert dict(d.perturbation.params) == {"mu": 1.0, "nu": 0.5}
    e = pulsemap.scene("default", R="-u*v")  # parameters the new R does not use are dropped
    assert dict(e.perturbation.params) == {}
    f = pulsemap.scene("default", R="alpha*u", **{"perturbation.params.alpha": -1})
    assert dict(f.perturbation.params) == {"alpha": -1.0}
    assert pulsemap.scene(a.as_dict()) == a


def _without_R(scene) -> dict:
    data = scene.as_dict()
    del data["perturbation"]["R"]
    return data


def test_scene_takes_a_sympy_R_as_derive_does():
    """scene(R=<sympy expr>) is scene(R=<the same formula as text>), as an override and in a dict; the
    scene's perturbation is derive's for the same expression (abs and exp(1) written in the parser's words)."""
    u, v, mu = sympy.symbols("u v mu")
    for expr, text in ((-mu * v * sympy.Abs(v), "-mu*v*abs(v)"), (-(u - mu * (1 - u**2) * v), "-(u - mu*(1-u^2)*v)"),
                       (-sympy.E * mu * v**3, "-exp(1)*mu*v^3")):
        a, b = pulsemap.scene("default", R=expr), pulsemap.scene("default", R=text)
        assert a.perturbation.R == b.perturbation.R and a.perturbation.params == b.perturbation.params
        assert _without_R(a) == _without_R(b)
        data = b.as_dict()
        data["perturbation"]["R"] = expr
        assert pulsemap.scene(data) == a
    d = pulsemap.derive(-(u - mu * (1 - u**2) * v), mu=3)
    sc = pulsemap.scene("default", R=-(u - mu * (1 - u**2) * v), mu=3)
    assert sc.perturbation.R == d.details.perturbation.R
    with pytest.raises(ValueError, match="unknown symbol 'pi'"):
        pulsemap.scene("default", R=-sympy.pi * mu * v)


@pytest.mark.parametrize("overrides, error, words", [
    ({"epss": 1}, ValueError, "'epss' (did you mean 'eps'?)"),
    ({"perturbation.eeps": 1}, ValueError, "did you mean 'perturbation.eps'"),
    ({"contacts": (40, 16)}, ValueError, "reversed"),
    ({"perturbation.params.nu": 1}, ValueError, "'nu' given but not used"),
    ({"velocity": "fast"}, ValueError, "velocity must be a number"),
])
def test_scene_bad_overrides(overrides, error, words):
    with pytest.raises(error) as info:
        pulsemap.scene("default", **overrides)
    assert words in str(info.value)


def test_scene_bad_argument_type():
    with pytest.raises(TypeError, match="name_or_path"):
        pulsemap.scene(42)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="did you mean"):
        pulsemap.scene("fig8-eps0.33")


# --------------------------------------------------------------------------- run


@pytest.fixture(scope="module")
def result():
    return pulsemap.run(pulsemap.scene("fig8-eps0.3", **SMALL), methods=["dns", "map", "longwave"])


def test_run_arrays_and_errors(result):
    assert list(result.contacts) == list(range(16, 31))
    assert result.methods == ("dns", "map", "longwave")
    for name in result.methods:
        assert result.peaks[name].shape == result.contacts.shape and result.peaks[name].dtype == float
    dns = result.peaks["dns"]
    assert np.all(np.isfinite(dns)) and np.all(np.diff(dns) < 0)  # damping: the pulse decays
    for name in ("map", "longwave"):  # errors recomputed from the arrays
        rel = np.abs(result.peaks[name] / dns - 1)
        assert result.errors[name]["live_range"] == [16, 30]  # the DNS peak stays above 2 % of the seed's
        assert result.errors[name]["unit"] == "percent"
        assert result.errors[name]["max_pct"] == pytest.approx(100 * np.nanmax(rel), rel=1e-12)
        assert result.errors[name]["rms_pct"] == pytest.approx(100 * np.sqrt(np.nanmean(rel ** 2)), rel=1e-12)
        assert result.errors[name]["compared"] == int(np.sum(np.isfinite(rel)))
    assert result.timings["dns"] > 0


def test_run_provenance(result):
    sc = pulsemap.scene("fig8-eps0.3", **SMALL)
    dns = result.produced_by["dns"]
    assert (dns["rtol"], dns["atol"]) == (sc.dns["rtol"], sc.dns["atol"])
    assert result.produced_by["map"]["variant"] == sc.variant and result.produced_by["map"]["profile"] == sc.profile
    seed = result.produced_by["map"]["seed"]
    assert seed["contact"] == 15 and seed["peak"] == dns["seed_peak"]
    assert result.provenance["pulsemap_version"] == pulsemap.__version__
    assert result.provenance["scene"]["perturbation"]["R"] == "-mu*v"
    assert "sympy" in json.dumps(result.provenance)


def test_run_renders(result, tmp_path):
    data = result.to_dict()
    assert json.loads(json.dumps(data)) == data and data is not result.data
    html = result._repr_html_()
    assert "fig8-eps0.3" in html and all(f"<td>{m}</td>" in html for m in result.methods)
    for name in ("map", "longwave"):  # the errors as every output shows them (3 significant digits)
        assert f"<td>{result.errors[name]['rms_pct']:.3g}</td>" in html
    assert f"pulsemap {pulsemap.__version__}" in html  # provenance
    assert "map" in repr(result) and "scene fig8-eps0.3" in str(result)


def test_every_result_object_has_a_short_one_line_repr(result):
    """repr names the object, its R and what it holds, on one line (the long report is str())."""
    free = pulsemap.derive("-mu*v")
    vdp = pulsemap.derive("-(u - mu*(1 - u^2)*v)", mu=3)
    shown = {
        repr(free): ("Derivation(", "'-mu*v'", "free=['mu']", "map (Eq. 23)", "law (power law)", "Eq. 41"),
        repr(vdp): ("Derivation(", "mu*(1 - u^2)", "law (quadrature)", "Eq. 41"),
        repr(pulsemap.derive("-k*u", k=[0.5] * 40)): ("Derivation(", "'-k*u'", "map (Eq. 23)"),
        repr(free.balance("momentum")): ("Balance(", "'momentum'", "'-mu*v'", "law (power law)"),
        repr(result): ("Result(", "'fig8-eps0.3'", "'-mu*v'", "'dns', 'map', 'longwave'"),
        repr(pulsemap.dressed("-mu*v", mu=1)): ("DressedDerivation(", "'-mu*v'", "1 monomial,", "0 cross terms"),
    }
    for text, words in shown.items():
        assert "\n" not in text and len(text) <= 160, text
        assert all(w in text for w in words), (text, words)
    assert "Eq. 41" not in repr(pulsemap.derive("-k*u", k=[0.5] * 40))  # a site-dependent R has none


def test_run_dataframe(result):
    pd = pytest.importorskip("pandas")
    frame = result.to_dataframe()
    assert isinstance(frame, pd.DataFrame) and frame.index.name == "contact"
    assert list(frame.columns) == ["dns", "map", "longwave", "dns_alive"]
    np.testing.assert_array_equal(frame["map"].to_numpy(), result.peaks["map"])


def test_run_plot(result, tmp_path):
    pytest.importorskip("matplotlib")
    path = tmp_path / "peaks.png"
    fig = result.plot(str(path))
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert {line.get_label() for line in fig.axes[0].get_lines()} >= {"DNS", "long-wave law"}
    assert fig._repr_png_()[:8] == b"\x89PNG\r\n\x1a\n"  # Jupyter shows it without %matplotlib inline


def test_missing_optional_packages_give_the_install_hint(result, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    monkeypatch.setitem(sys.modules, "matplotlib.figure", None)
    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(ImportError, match=r'pip install "pulsemap\[notebook\]"'):
        result.plot()
    with pytest.raises(ImportError, match=r'pip install "pulsemap\[notebook\]"'):
        result.to_dataframe()


def test_run_without_dns_and_choices():
    r = pulsemap.run("fig8-eps0.3", methods="map", variant="1d")
    assert r.methods == ("map",) and r.errors == {}
    assert r.produced_by["map"]["variant"] == "1d"
    assert r.produced_by["map"]["seed"]["from"].startswith("impulse v0")


@pytest.mark.parametrize("call, error, words", [
    (lambda: pulsemap.run(42), TypeError, "scene must be"),
    (lambda: pulsemap.run("default", methods=["mapp"]), ValueError, "did you mean 'map'"),
    (lambda: pulsemap.run("default", methods=[1]), TypeError, "methods must be"),
    (lambda: pulsemap.run("default", methods=[]), ValueError, "methods is empty"),
    (lambda: pulsemap.run("default", methods="map", profile="exat"), ValueError, "exact"),
    (lambda: pulsemap.run("default", methods="map", variant=1), TypeError, "variant must be a string"),
    (lambda: pulsemap.run("default", methods="map", rank=True), ValueError, "add 'dns' to the methods"),
    (lambda: pulsemap.run("default", methods="map", rank=1), TypeError, "rank must be True or False"),
])
def test_run_bad_input(call, error, words):
    with pytest.raises(error) as info:
        call()
    assert words in str(info.value)


def test_every_method_is_in_the_method_lists_of_help_and_run_help(capsys):
    import pydoc

    from pulsemap.solvers.cli.main import main
    from pulsemap.solvers.data.scene.schema import METHODS

    doc = pydoc.render_doc(pulsemap.run, renderer=pydoc.plaintext)
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    cli = " ".join(capsys.readouterr().out.split())
    for method in METHODS:
        assert f'"{method}"' in doc and method in cli, method
    assert "relaxed" in cli and "dressed-law" in cli
