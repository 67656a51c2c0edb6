"""Universal constants f1..f7, g^(1), g^(2) (Eqs. 17, 22, 23) with mpmath."""

import time

import numpy as np
import pytest

from pulsemap.symbolic import integrals
from pulsemap.symbolic.integrals import F_NAMES, constants, g1, g2
from pulsemap.symbolic.profile import exact_profile


def _simpson(profile, func, lo, hi=0.0, m=20000):
    """An independent quadrature (composite Simpson on the vectorised profile)."""
    t = np.linspace(lo, hi, 2 * m + 1)
    y = func(t)
    h = (hi - lo) / (2 * m)
    return h / 3 * (y[0] + y[-1] + 4 * y[1:-1:2].sum() + 2 * y[2:-1:2].sum())


@pytest.mark.parametrize("profile", ["exact", "pade"])
def test_contact_sum_vanishes(profile):
    f = constants(F_NAMES, profile=profile)
    # f1 - 2 f2 + f3 = S'(0) = 0 (Eq. 41's cancellation)
    assert abs(f["f1"].value - 2 * f["f2"].value + f["f3"].value) < 1e-10
    assert f["f5"].value == f["f2"].value and f["f6"].value == f["f3"].value


def test_f4_is_a_point_value_and_eq4_integrated():
    p = exact_profile(1.5)
    f = constants(F_NAMES)
    # f4 = int S''(t-1) dt = S'(-1)
    assert f["f4"].value == pytest.approx(float(p.dS(-1.0)), abs=1e-9)
    # Integrating Eq. 4 over (-inf, -1]: S'(-1) = f7 - 2 f6 + f5 (erratum 5, docs/errata.rst)
    assert f["f4"].value == pytest.approx(f["f7"].value - 2 * f["f6"].value + f["f5"].value, abs=1e-9)
    assert f["f7"].value > 1e-5  # the dropped term is small but not zero


@pytest.mark.parametrize("n", [1.5, 2.5])
def test_exact_derivative_integrals_reduce_to_point_values(n):
    p = exact_profile(n)
    assert g1(0, 0, 1, 0, n=n).value == pytest.approx(p.S0, abs=1e-10)  # int S' = S(0)
    assert g1(0, 0, 0, 1, n=n).value == pytest.approx(float(p.S(-1.0)), abs=1e-10)
    assert g2(0, 1, n=n).value == pytest.approx(float(p.S(-1.0)), abs=1e-10)
    # int S^2 S' = S(0)^3 / 3 and int S(t-1)^3 S'(t-1) = S(-1)^4 / 4
    assert g1(2, 0, 1, 0, n=n).value == pytest.approx(p.S0**3 / 3, rel=1e-10)
    assert g2(3, 1, n=n).value == pytest.approx(float(p.S(-1.0)) ** 4 / 4, rel=1e-9)


def test_mass_identity_of_the_fixed_point():
    """S = Lambda * S^n implies int_-inf^0 S = int_-inf^0 S^n, i.e. g1_1000 = f2."""
    assert g1(1, 0, 0, 0).value == pytest.approx(constants(F_NAMES)["f2"].value, rel=1e-10)


@pytest.mark.parametrize(
    "exps",
    [(3, 0, 0, 0), (2, 1, 0, 0), (1, 2, 0, 0), (0, 1, 1, 0), (1, 1, 1, 1), (0, 0, 2, 0), (2, 0, 0, 3)],
)
def test_g1_against_independent_quadrature(exps):
    k, l, m, q = exps
    p = exact_profile(1.5)
    func = lambda t: p.S(t) ** k * p.S(t - 1) ** l * p.dS(t) ** m * p.dS(t - 1) ** q  # noqa: E731
    ref = _simpson(p, func, -12.0)
    assert g1(*exps).value == pytest.approx(ref, rel=1e-9, abs=1e-13)


@pytest.mark.parametrize("exps", [(1, 0), (3, 0), (2, 1), (0, 2)])
def test_g2_against_independent_quadrature(exps):
    pp, r = exps
    p = exact_profile(1.5)
    ref = _simpson(p, lambda t: p.S(t - 1) ** pp * p.dS(t - 1) ** r, -12.0)
    assert g2(*exps).value == pytest.approx(ref, rel=1e-9, abs=1e-13)


def test_pade_constants_close_to_exact_but_distinct():
    ex = constants(["g1_1000", "g1_3000"], profile="exact")
    pa = constants(["g1_1000", "g1_3000"], profile="pade")
    for name in ex:
        rel = abs(pa[name].value - ex[name].value) / ex[name].value
        assert 1e-8 < rel < 1e-2
        assert pa[name].profile == "pade" and pa[name].dps == 30


def test_cache_makes_second_call_free(monkeypatch):
    names = ["g1_4000", "g2_20"]
    t0 = time.perf_counter()
    first = constants(names, n=1.7)
    cold = time.perf_counter() - t0
    # A second call must not compute anything: make computing fail.
    monkeypatch.setattr(integrals, "_compute", lambda *a: (_ for _ in ()).throw(AssertionError("recomputed")))
    second = constants(names, n=1.7)
    assert {k: v.value for k, v in first.items()} == {k: v.value for k, v in second.items()}
    assert cold > 0
    # a different precision is a different cache entry
    with pytest.raises(AssertionError, match="recomputed"):
        constants(names, n=1.7, dps=18)


def test_only_requested_integrals_are_computed(monkeypatch):
    seen = []
    real = integrals._compute
    monkeypatch.setattr(integrals, "_compute", lambda prof, name, dps: seen.append(name) or real(prof, name, dps))
    constants(["g1_0300"], n=1.9)
    assert seen == ["g1_0300"]


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: g1(-1, 0, 0, 0), "non-negative integer"),
        (lambda: g2(0, 0), "diverges"),
        (lambda: g1(1.5, 0, 0, 0), "non-negative integer"),
        (lambda: constants(["h1_10"]), "unknown integral"),
        (lambda: constants(["g1_10"]), "malformed"),
        (lambda: constants(["f1"], profile="spline"), "unknown profile"),
        (lambda: constants(["f1"], dps=3), "precision"),
    ],
)
def test_bad_requests_are_clear_errors(call, match):
    with pytest.raises(ValueError, match=match):
        call()
