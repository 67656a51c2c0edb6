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
    assert out[1] == str(sorted(["Derivation", "Result", "__version__", "derive", "dressed", "run", "scene", "scenes"]))
    for name in pulsemap.__all__:
        assert getattr(pulsemap, name) is not None


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


def _sym(text: str, extra: dict | None = None):
    names = {"B": sympy.Function("B"), "i": sympy.Symbol("i", real=True)}
    return sympy.sympify(text, locals={**names, **(extra or {})})


def test_damping_law_solves_its_long_wave_ode():
    """A(i) of the derivation, with B = A^((n+1)/2), satisfies the printed Eq. 30 with the printed constants."""
    d = pulsemap.derive("-mu*v", mu=1, eps=0.1)
    assert d.law_kind == "power law" and d.law.startswith("A(i) = ")
    i = sympy.Symbol("i", real=True)
    A0, i0, k = sympy.symbols("A_0 i_0 k", real=True)
    law = _sym(d.law.split("=", 1)[1], {"A_0": A0, "i_0": i0, "k": k, "lambda_L": k})  # the rate prints as lambda_L
    lhs, rhs = (_sym(side) for side in d.ode.split(" = "))
    values = {sympy.Symbol(name): value for name, value in d.constants.items()}
    values.update({sympy.Symbol("epsilon"): d.eps, sympy.Symbol("mu"): 1})

    def residual(rate: float, at: float) -> tuple[float, float]:
        B = law.subs({k: rate, A0: 0.8, i0: 15}) ** sympy.Rational(5, 4)  # P = (n + 1)/2 at n = 3/2
        sides = [side.subs(values).subs(sympy.Function("B")(i), B).doit().subs(i, at) for side in (lhs, rhs)]
        return float(sides[0] - sides[1]), float(abs(sides[1]))

    for at in (15.0, 20.0, 40.0):
        r, scale = residual(d.rate, at)
        assert abs(r) <= 1e-12 * scale
    r, scale = residual(1.1 * d.rate, 20.0)  # a wrong rate does not solve it (the check can fail)
    assert abs(r) > 0.05 * scale


def test_van_der_pol_roots_solve_eq41():
    d = pulsemap.derive("-(u - mu*(1 - u^2)*v)", mu=3, eps=0.1)
    assert len(d.roots) == 2 and all(r > 0 for r in d.roots)
    phi = _sym(d.stationary.split("=", 1)[1], {"A": sympy.Symbol("A")})
    values = {sympy.Symbol(name): value for name, value in d.constants.items()}
    values[sympy.Symbol("mu")] = 3
    f = sympy.lambdify(sympy.Symbol("A"), phi.subs(values))
    for root in d.roots:
        assert abs(f(root)) < 1e-9 * abs(f(2 * root))
    assert d.stationary_peaks == pytest.approx(tuple(r * d.S0 for r in d.roots))


@pytest.mark.parametrize("k", [[0.5] * 40, "0.5 + 0.01*i"], ids=["per-bead", "expression-of-i"])
def test_site_dependent_derivation(k):
    """A site-dependent R: the map keeps the (k_{i+1} - k_i) term, the law has coefficients C_p(i), no Eq. 41."""
    d = pulsemap.derive("-k*u", k=k)
    assert any("g1_0100" in eq for eq in d.map)
    assert d.ode is not None and "Derivative" in d.ode and d.rate is None
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
    assert latex.startswith("$$") and r"\tag{41}" in latex and r"\tag{23.1}" in latex
    assert d.params == {"mu": 1.0} and d.profile == "exact" and d.n == 1.5


def test_derive_choices_reach_the_derivation():
    a = pulsemap.derive("-mu*v", mu=1, variant="1d", profile="pade")
    b = pulsemap.derive("-mu*v", params={"mu": 1})
    assert (a.variant, a.profile) == ("1d", "pade") and a.rate != b.rate and a.constants != b.constants
    assert a.map != b.map


@pytest.mark.parametrize("call, error, words", [
    (lambda: pulsemap.derive(1), TypeError, "R must be a string"),
    (lambda: pulsemap.derive("-mu*v"), ValueError, "mu=VALUE"),
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


def test_scenes_lists_the_builtins():
    names = pulsemap.scenes()
    assert names == builtin_scenes() and "fig8-eps0.3" in names


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
        assert result.errors[name]["max_rel"] == pytest.approx(np.nanmax(rel), rel=1e-12)
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
    assert "map" in repr(result) and "scene fig8-eps0.3" in str(result)


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


def test_missing_optional_packages_give_the_install_hint(result, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    monkeypatch.setitem(sys.modules, "matplotlib.figure", None)
    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(ImportError, match=r'pip install "pulsemap\[plot\]"'):
        result.plot()
    with pytest.raises(ImportError, match="pip install pandas"):
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
])
def test_run_bad_input(call, error, words):
    with pytest.raises(error) as info:
        call()
    assert words in str(info.value)
