"""Generated solver code: generated modules and the map, law and stationary solvers."""

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy

from conftest import regenerated
from pulsemap.symbolic import codegen
from pulsemap.symbolic.amplitude_map import A_I, A_NEXT, A_PREV, EPS, AmplitudeMap
from pulsemap.symbolic.expansion import expand
from pulsemap.symbolic.expression import parse_expression, symbol
from pulsemap.symbolic.integrals import METHOD_VERSION
from pulsemap.symbolic.sources import INTEGRALS_METHOD, GeneratedCodeError, verify_generated
from pulsemap.solvers.models.codeload import GeneratedModuleError, _load_path, force_module, map_module
from pulsemap.solvers.models.map_iteration import iterate_map
from pulsemap.solvers.models.map_bracket import fallback as _fallback
from pulsemap.solvers.models.map_step import _newton
from pulsemap.solvers.models.stationary_shock import continue_roots, roots, stability

GENERATED = Path(codegen.PACKAGE_DIR)
VDP = "-(u - mu*(1 - u^2)*v)"


def test_sources_version_tracks_integrals_version():
    assert INTEGRALS_METHOD == METHOD_VERSION


SHIPPED = sorted(p for p in GENERATED.glob("*.py") if p.name != "__init__.py")


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_regenerating_committed_modules_changes_nothing(path, tmp_path):
    assert regenerated(path, tmp_path) == path.read_text(encoding="utf-8")


def test_committed_modules_cover_the_builtin_scenes():
    kinds = [p.name.split("_")[0] for p in SHIPPED]
    assert set(kinds) == {"map", "force", "balance"} and len(SHIPPED) == 16
    assert all(kinds.count(kind) >= 5 for kind in ("map", "force", "balance"))


@pytest.mark.parametrize("noise", [1e-13, -1e-13])
def test_constants_noise_below_their_accuracy_leaves_the_code_unchanged(monkeypatch, tmp_path, noise):
    """The quadrature constants and S0 computed on another machine (another numpy build: a profile that
    differs far below its accuracy, ~1e-10) regenerate every shipped module to the same bytes. 1e-13 is
    3x the change that moved w_21's 12th digit when constants were printed to 12 digits; S0 (and
    g1_0010 = S0) sits 4e-13 from a rounding boundary at its accuracy, the closest of all."""
    import dataclasses

    from pulsemap.symbolic import balance, codegen_map, codeprint

    def shaken(compute):
        def wrapped(*args, **kwargs):
            return {k: dataclasses.replace(c, value=c.value * (1 + noise)) for k, c in compute(*args, **kwargs).items()}
        return wrapped

    monkeypatch.setattr(codegen_map, "constants", shaken(codegen_map.constants))
    monkeypatch.setattr(balance, "balance_constants", shaken(balance.balance_constants))
    get_profile = codeprint.get_profile
    monkeypatch.setattr(codeprint, "get_profile", lambda *a: dataclasses.replace(get_profile(*a), S0=get_profile(*a).S0 * (1 + noise)))
    for path in SHIPPED:
        assert regenerated(path, tmp_path) == path.read_text(encoding="utf-8"), path.name


def test_printed_constants_are_rounded_at_their_accuracy():
    from pulsemap.symbolic.codeprint import SIG_DIGITS, measured

    assert measured(7.035343498574802, 1.25e-8) == 7.0353435  # the decade of the bound: 1e-8
    assert measured(0.0007231591399401392, 1.18e-10) == 0.0007231591
    assert measured(2.0 / 3.0, 0.0) == float(f"{2 / 3:.{SIG_DIGITS}g}")  # exact: SIG_DIGITS digits
    assert measured(3e-17, 1e-10) == 0.0  # below its bound: zero
    for value, error in [(1.5686037157903603, 2.79e-9), (13.555942020703633, 2.4e-8), (-0.1234567891234, 3e-11)]:
        printed = measured(value, error)
        assert abs(printed - value) <= error  # no farther from the computed value than its bound
        assert measured(value * (1 + 1e-13), error) == printed  # a machine's noise does not move it


def test_hand_edited_module_is_refused(tmp_path):
    src = next(GENERATED.glob("map_*.py"))
    edited = tmp_path / src.name
    edited.write_text(src.read_text().replace("f1 = ", "f1 = 1.0 + "), encoding="utf-8")
    with pytest.raises(GeneratedModuleError, match=f"{edited}.*content-hash"):
        _load_path(edited)
    with pytest.raises(GeneratedCodeError, match="content-hash"):
        verify_generated(edited.read_text())


@pytest.mark.process
def test_lookup_of_existing_code_does_not_import_sympy():
    code = (
        "import sys; from pulsemap.solvers.models.codeload import map_module, force_module; "
        f"map_module({VDP!r}, ['mu'], 1.5, 'exact', 'paper'); force_module({VDP!r}, ['mu']); "
        "print('sympy' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def _sympy_map(mod, text, params, variant):
    """The sympy equations of derive, evaluated with the constants embedded in the module."""
    R = parse_expression(text, params)
    ex = expand(R, 1.5)
    names = ["f1", "f2", "f3", "f4", "f5", "f6", "f7"] + list(ex.integrals())
    consts = {k: float(getattr(mod, k)) for k in names}
    return AmplitudeMap(ex.n, variant, ex, consts, {})


@pytest.mark.parametrize("variant", ["paper", "corrected", "1d"])
def test_generated_code_equals_the_sympy_equations(variant):
    mod = map_module(VDP, ["mu"], 1.5, "exact", variant)
    amap = _sympy_map(mod, VDP, ["mu"], variant)
    eqs = amap.equations(numeric=False)
    vals = {sympy.Symbol(k, real=True): v for k, v in amap.constants.items()}
    rng = np.random.default_rng(3)
    for _ in range(5):
        a, b, c, eps, mu = rng.uniform(0.2, 2.0, 5)
        pt = {A_PREV: a, A_I: b, A_NEXT: c, EPS: eps, symbol("mu"): mu}
        direct = [float(e.xreplace(vals).xreplace(pt)) for e in eqs]
        state = (a, b) if variant == "1d" else (a, b, c)
        gen = mod.map_residual(*state, eps, mu)
        assert gen == pytest.approx(direct, rel=1e-13, abs=1e-14)
        # Jacobian against finite differences of the generated residual
        jac, dprev = mod.map_jacobian(*state, eps, mu)
        h = 1e-6
        for j, _unk in enumerate(state[1:]):
            up = list(state); up[j + 1] += h  # noqa: E702
            dn = list(state); dn[j + 1] -= h  # noqa: E702
            fd = (np.array(mod.map_residual(*up, eps, mu)) - np.array(mod.map_residual(*dn, eps, mu))) / (2 * h)
            assert [row[j] for row in jac] == pytest.approx(fd, rel=1e-7, abs=1e-9)


@pytest.mark.parametrize("variant", ["corrected", "1d"])
def test_unperturbed_map_keeps_amplitude_constant(variant):
    mod = map_module("-mu*v", ["mu"], 1.5, "exact", variant)
    run = iterate_map(mod, 0.6, 15, 215, 0.0, {"mu": 1.0})
    assert run.status == "ok" and len(run.A) == 200
    assert np.max(np.abs(run.A / 0.6 - 1)) < 1e-13


def test_literal_map_drifts_as_errata_5_predicts():
    """eps = 0: f1 A_{i-1}^P = (f1 + f7/2) A_i^P per step, i.e. A ratio (1 + f7/(2 f1))^(-1/P)."""
    mod = map_module("-mu*v", ["mu"], 1.5, "exact", "paper")
    run = iterate_map(mod, 0.6, 15, 115, 0.0, {"mu": 1.0})
    predicted = (1 + mod.f7 / (2 * mod.f1)) ** (-1 / mod.P)
    measured = run.A[1:] / run.A[:-1]
    assert measured == pytest.approx(np.full_like(measured, predicted), rel=1e-12)
    drift = run.A[-1] / 0.6 - 1
    assert drift == pytest.approx(predicted**100 - 1, rel=1e-9)
    assert -0.02 < drift < -0.005  # about -1.2 % over 100 contacts


def test_newton_and_bracketing_fallback_agree():
    mod = map_module(VDP, ["mu"], 1.5, "exact", "paper")
    a = _newton(mod, 0.7, (0.7, 0.7), 0.1, (3.0,))
    b = _fallback(mod, 0.7, 0.1, (3.0,), True)
    assert a == pytest.approx(b, rel=1e-10)


def test_van_der_pol_stable_and_unstable_stationary_amplitudes():
    def analyse(mod):
        """(A, fixed point, multiplier, stable) at each root of Eq. 41 (mu = 3, eps = 0.1)."""
        return [(a, *stability(mod, a, 0.1, {"mu": 3.0})) for a in roots(mod, {"mu": 3.0})]

    for variant in ("1d", "corrected"):
        found = analyse(map_module(VDP, ["mu"], 1.5, "exact", variant))
        assert len(found) == 2
        (_, _, lam_small, stable_small), (_, _, lam_large, stable_large) = found
        assert lam_small > 1 and stable_small is False
        assert 0 < lam_large < 1 and stable_large is True
    # the literal map: shifted fixed point near the large root, still stable
    _, (a_large, fixed, _, stable) = analyse(map_module(VDP, ["mu"], 1.5, "exact", "paper"))
    assert fixed > a_large and stable


def test_fold_by_continuation_equals_the_derivation():
    from pulsemap.symbolic.derivation import derive_all
    from pulsemap.symbolic.perturbation import make_perturbation

    mod = map_module(VDP, ["mu"], 1.5, "exact", "1d")
    cont = continue_roots(mod, {"mu": 3.0}, "mu", 1.0, 4.0, 61)
    assert len(cont.folds) == 1
    mu_star, a_star = cont.folds[0]
    d = derive_all(make_perturbation(VDP, 0.1, {"mu": 3}), fold="mu")
    assert mu_star == pytest.approx(d.stationary.fold.value, rel=1e-8)
    assert a_star == pytest.approx(d.stationary.fold.A, rel=1e-6)
    counts = [len(b) for b in cont.branches]
    assert counts[0] == 0 and counts[-1] == 2


def test_force_module_derivatives():
    mod = force_module(VDP, ["mu"])
    rng = np.random.default_rng(0)
    x, v = rng.normal(size=6), rng.normal(size=6)
    i = np.arange(1, 7.0)
    eps = np.full(6, 0.1)
    h = 1e-6
    fdx = (mod.force(x + h, v, i, eps, 3.0) - mod.force(x - h, v, i, eps, 3.0)) / (2 * h)
    fdv = (mod.force(x, v + h, i, eps, 3.0) - mod.force(x, v - h, i, eps, 3.0)) / (2 * h)
    assert np.allclose(mod.force_dx(x, v, i, eps, 3.0), fdx, rtol=1e-7, atol=1e-9)
    assert np.allclose(mod.force_dv(x, v, i, eps, 3.0), fdv, rtol=1e-7, atol=1e-9)
    expected = -(x - 3.0 * (1 - x**2) * v) * 0.1
    assert np.allclose(mod.force(x, v, i, eps, 3.0), expected, rtol=1e-14)


def test_site_dependent_map_uses_per_bead_values():
    mod = map_module("-k*u", ["k"], 1.5, "exact", "paper", ("k",))
    assert mod.PARAMS == ("k",) and mod.ARGS == (("k", 0), ("k", 1))
    k = np.linspace(0.1, 0.9, 140)
    run = iterate_map(mod, 0.5, 15, 30, 0.5, {"k": k})
    # uniform k gives the same as the uniform map with that value
    uni = map_module("-k*u", ["k"], 1.5, "exact", "paper")
    r1 = iterate_map(mod, 0.5, 15, 30, 0.5, {"k": np.full(140, 0.3)})
    r2 = iterate_map(uni, 0.5, 15, 30, 0.5, {"k": 0.3})
    assert r1.A == pytest.approx(r2.A, rel=1e-13)
    assert not np.allclose(run.A[: len(r1.A)], r1.A[: len(run.A)])
    assert all(math.isfinite(a) for a in run.A)


@pytest.mark.parametrize("text, name, eps", [("beta*u^3", "beta", 0.3), ("-c*v", "c", 0.3)])
def test_closed_form_longwave_law_ends_as_the_derivation_says(text, name, eps):
    """The generated closed-form law (Eq. 30) ends where, and as (extinction / blow-up), the symbolic
    law's singular index says; the amplitudes before the end move the same way."""
    from pulsemap.symbolic.longwave import longwave_law

    from pulsemap.solvers.models.longwave_eval import evaluate_law

    mod = map_module(text, [name], 1.5, "exact", "paper")
    R = parse_expression(text, [name])
    ex = expand(R, 1.5)
    consts = {k: float(getattr(mod, k)) for k in ["f1", "f2", "f3", "f4", "f5", "f6", "f7"] + list(ex.integrals())}
    law = longwave_law(AmplitudeMap(ex.n, "paper", ex, consts, {symbol(name): 1}), eps)
    index, what = law.singular_index(1.0, 0.0)
    run = evaluate_law(mod, 1.0, 0.0, np.arange(1, 200), eps, {name: 1.0})
    assert index is not None and run.ended_at == pytest.approx(index, rel=1e-9)
    assert what.startswith(run.ended)
    values = [a for a in run.A if a is not None]
    assert (values[-1] > values[0]) == (run.ended == "blow-up")
