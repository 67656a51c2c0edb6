"""The contact-law derivation: monomial split and its refusals, I_ab and E_1 by independent methods, the energy
law against its ODE, the elastic first-order wave against the nonlinear travelling wave."""

from __future__ import annotations

import numpy as np
import pytest
import sympy

from pulsemap.symbolic.balance_constants import balance_constants
from pulsemap.symbolic.contact import (ContactError, ContactMonomial, check_contact_model, combined_energy_law,
                                       contact_constants, contact_energy_law, contact_integral_name, contact_map_terms,
                                       contact_monomials, contact_to_json, contact_to_text, derive_contact,
                                       half_line_integral_name)
from pulsemap.symbolic.contact_wave import elastic_constants, first_order_profile, taper_law
from pulsemap.symbolic.longwave import A0, I, I0
from pulsemap.symbolic.profile import exact_profile

d, w, gamma = sympy.symbols("d w gamma", real=True)
half = sympy.Rational(1, 2)
NS = (1.5, 2.0, 2.5, 3.0)


# ----------------------------------------------------------------------------- input form
def test_split_into_monomials():
    P = gamma * sympy.sqrt(d) * w + 3 * w - 2 * d ** sympy.Rational(5, 2) + w * (d + w**2)
    got = {(m.a, m.b): m.coef for m in contact_monomials(P)}
    assert got == {(0, 1): 3, (half, 1): gamma, (sympy.Rational(5, 2), 0): -2, (1, 1): 1, (0, 3): 1}
    assert contact_monomials(sympy.Integer(0)) == ()


@pytest.mark.parametrize("P, words", [
    (1 / d * w, "negative power of d"),
    (sympy.sqrt(w) * d, "powers of w must be non-negative integers"),
    (d / w, "powers of w must be non-negative integers"),
    (d**2 + 5, "force at zero overlap"),
    (sympy.sin(d) * w, "not a finite sum"),
    ((1 + d) ** half * w, "not a finite sum"),
    (d ** gamma, "not a finite sum"),
    (sympy.Symbol("u") * w, "uses u"),
    (sympy.zoo * w, "not a finite real"),
    (sympy.I * w, "not a finite real"),
    (sympy.sqrt(d * w), "not a finite sum"),
    (sympy.Symbol("i") * d, "uses i"),
    (sympy.Symbol("v") * d, "uses v"),
])
def test_refusals(P, words):
    with pytest.raises(ContactError, match=words):
        contact_monomials(P)


# ----------------------------------------------------------------------------- constants
def _grid_integral(n: float, a, b: int) -> float:
    """int S^a S'^(b+1) by the trapezoid rule on the profile's own nodes (not the Hermite interpolant, not mpmath)."""
    prof = exact_profile(n)
    s, ds = np.maximum(prof.nodes[:, 0], 0.0), prof.nodes[:, 1]
    return float(np.sum(np.where(s > 0, s ** float(a), 0.0) * ds ** (b + 1)) * prof.h)


@pytest.mark.parametrize("n", NS)
def test_I_ab_against_grid_quadrature(n):
    names = {(a, b): contact_integral_name(a, b) for a, b in [(0, 1), (half, 1), (1, 1), (sympy.Rational(5, 2), 3)]}
    got = contact_constants(names.values(), n=n)
    for (a, b), name in names.items():
        ref = _grid_integral(n, a, b)
        assert got[name].value == pytest.approx(ref, rel=1e-10), name
        assert got[name].value > 0  # S'^(even) >= 0


@pytest.mark.parametrize("n", NS)
def test_I_ab_vanishes_for_even_b(n):
    names = [contact_integral_name(a, b) for a, b in [(1, 0), (half, 2), (sympy.Rational(5, 2), 0)]]
    scale = contact_constants([contact_integral_name(1, 1)], n=n)[contact_integral_name(1, 1)].value
    for name, c in contact_constants(names, n=n).items():
        assert abs(c.value) < 1e-12 * scale, name


@pytest.mark.parametrize("n", NS)
def test_E1_against_the_lattice_sum_of_a_chain_state(n):
    """E_1 (the integral form) equals the energy of the exact-wave chain state summed bead by bead, at any phase."""
    prof = exact_profile(n)
    wave = balance_constants(["K1", "V1"], n=n)
    E1 = wave["K1"].value + wave["V1"].value
    k = np.arange(-60, 61)
    for theta in (0.0, 0.3, 0.71):
        strain = prof.S(theta - k)  # delta_k, the wave at phase theta
        speed = np.cumsum(prof.dS(theta - k)[::-1])[::-1]  # x_i' = sum_{k >= i} delta_k'
        energy = np.sum(speed**2) / 2 + np.sum(np.maximum(strain, 0) ** (n + 1)) / (n + 1)
        assert energy == pytest.approx(E1, rel=1e-10)


# ----------------------------------------------------------------------------- energy law
@pytest.mark.parametrize("P, n", [(w, 1.5), (sympy.sqrt(d) * w, 1.5), (gamma * d * w, 2.0), (w**3, 2.5)])
def test_closed_form_solves_its_ode(P, n):
    eps = 0.03
    law = contact_energy_law(P, n=n, eps=eps, params={"gamma": 0.7})
    assert law.kind == "power law"
    (mono,) = contact_monomials(P)
    q = mono.q(n)
    assert q == mono.work_power(n) - sympy.Rational(str(n))
    assert law.powers[0] * law.Q == mono.work_power(n)  # B's power times Q: A's power in the work
    # substitute A(i) back: E_1 d(A^(n+1))/di = eps C A^(work power)
    A_i = law.numeric_law()
    B_i = A_i ** law.Q
    residual = law.K * sympy.diff(B_i, I) - eps * law.coefficients[0] * B_i ** law.powers[0]
    f = sympy.lambdify((I,), residual.subs({A0: 1.3, I0: 2.0}))
    scale = abs(eps * law.coefficients[0]) * 1.3 ** float(law.Q * law.powers[0])
    for i in (2.0, 5.5, 11.0):
        assert abs(f(i)) < 1e-12 * scale
    # the rate: dA/dk = -eps c I A^q / ((n+1) E1) at A0
    c = 0.7 if mono.coef == gamma else 1.0
    I_ab = contact_constants([mono.integral], n=n)[mono.integral].value
    dA = sympy.diff(A_i, I).subs({A0: 1.3, I0: 2.0, I: 2.0})
    assert float(dA) == pytest.approx(-eps * c * I_ab * 1.3 ** float(q) / ((n + 1) * law.K), rel=1e-12)


def test_mass_factor_and_elastic_terms():
    m = sympy.Symbol("m", positive=True)
    law = derive_contact(contact_monomials(w + w**3 + d**3), 1.5, 0.01, mass=m).law
    assert law.kind == "quadrature"  # m has no value: two powers, numeric coefficients needed
    exps = {sympy.Rational(p) * law.Q: c for p, c in zip(law.powers, law.symbolic_coefficients)}
    assert set(exps) == {sympy.Rational(9, 4), sympy.Rational(19, 4)}  # the even-b term d^3 does no work
    assert sympy.simplify(exps[sympy.Rational(9, 4)] * sympy.sqrt(m)).free_symbols == {sympy.Symbol("I_0_1", real=True)}
    assert sympy.simplify(exps[sympy.Rational(19, 4)] * m ** sympy.Rational(3, 2)).free_symbols == {
        sympy.Symbol("I_0_3", real=True)}
    assert derive_contact(contact_monomials(d**3), 1.5, 0.01).law.kind == "constant"


def test_report_and_json():
    import json

    D = derive_contact(contact_monomials(gamma * sympy.sqrt(d) * w + d ** sympy.Rational(5, 2)), 1.5, 0.05,
                       params={"gamma": 2.0})
    data = json.loads(json.dumps(contact_to_json(D, A0=1.0, i0=15)))
    assert data["wave"]["E1"] == pytest.approx(D.E1)
    assert data["law"]["rate_k"] == pytest.approx(-0.05 * 2.0 * D.constants["I_1/2_1"] / D.E1, rel=1e-12)
    assert data["elastic"][0]["jump"] == D.elastic[0].jump
    text = contact_to_text(D)
    assert "I_1/2_1" in text and "entry jump" in text


def test_refusals_of_the_law():
    with pytest.raises(ContactError, match="contact index k"):
        derive_contact(contact_monomials(sympy.Symbol("k", real=True) * w), 1.5, 0.01)
    with pytest.raises(ContactError, match="momentum"):
        check_contact_model("momentum-law", contact_monomials(w))
    assert check_contact_model("momentum-law", ()) == "momentum-law"


def test_combined_with_onsite_energy_law():
    from pulsemap.symbolic.balance import derive_balance
    from pulsemap.symbolic.perturbation import make_perturbation

    onsite = derive_balance(make_perturbation("-v", eps=0.01), "energy", n=1.5)
    contact = derive_contact(contact_monomials(w), 1.5, 0.02)
    law = combined_energy_law(onsite, contact)
    # both terms have work power 9/4: one coefficient, the sum of the two laws' eps C
    assert len(law.powers) == 1
    assert law.coefficients[0] == pytest.approx(onsite.law.eps * onsite.law.coefficients[0]
                                                + contact.law.eps * contact.law.coefficients[0], rel=1e-14)
    with pytest.raises(ContactError, match="momentum"):
        combined_energy_law(derive_balance(make_perturbation("-v", eps=0.01), "momentum", n=1.5), contact)


# ----------------------------------------------------------------------------- the map's contact term
@pytest.mark.parametrize("n", [1.5, 2.5])
def test_half_line_integrals_of_a_derivative(n):
    """b = 1: S^a S' = (S^(a+1)/(a+1))', so J<shift>_a1 = S(shift)^(a+1)/(a+1) exactly."""
    prof = exact_profile(n)
    for a in (0, half, 2):
        names = {shift: half_line_integral_name(shift, a, 1) for shift in (1, 0, -1, -2)}
        got = contact_constants(names.values(), n=n)
        for shift, name in names.items():
            exact = float(prof.S(float(shift))) ** (float(a) + 1) / (float(a) + 1)
            assert got[name].value == pytest.approx(exact, rel=1e-10, abs=1e-14), name
    with pytest.raises(ContactError, match="shifts"):
        half_line_integral_name(2, 0, 1)


def test_map_terms_by_variant():
    from pulsemap.symbolic.amplitude_map import A_I, A_NEXT, A_PREV

    mono = contact_monomials(gamma * w + d**3)
    f1, f2, values = contact_map_terms(mono, 1.5, "corrected")
    assert {x.name for x in f2.free_symbols} >= {"Jm2_0_1", "Jm2_3_0"}
    f1d, f2d, _ = contact_map_terms(mono, 1.5, "1d")
    assert f2d is None and A_NEXT not in f1d.free_symbols
    _, f2p, _ = contact_map_terms(mono, 1.5, "paper")
    assert not any(x.name.startswith("Jm2") for x in f2p.free_symbols)
    # equal amplitudes: the dashpot's F1 term is eps gamma A (Jp1 - 2 J0 + Jm1) = 2 eps gamma A (S(1) - S(0))
    prof = exact_profile(1.5)
    ints = {sympy.Symbol(k, real=True): v for k, v in values.items()}
    uniform = f1.xreplace(ints).subs({A_PREV: 1.3, A_I: 1.3, A_NEXT: 1.3, gamma: 1, sympy.Symbol("epsilon", positive=True): 1})
    # ... and an even integrand's half-line second difference, int_0^1 S^3 - int_(-1)^0 S^3, vanishes
    assert abs(values["Jp1_3_0"] - 2 * values["J0_3_0"] + values["Jm1_3_0"]) < 1e-12
    assert values["J0_3_0"] > 0.1
    assert float(uniform) == pytest.approx(2 * 1.3 * (float(prof.S(1.0)) - prof.S0), rel=1e-10)


# ----------------------------------------------------------------------------- elastic correction
def _nonlinear_wave(n: float, a: float, eps: float, stride: int = 8) -> np.ndarray:
    """The travelling wave g = Lambda * (g^n + eps g^a) at unit speed, by Petviashvili iteration on the coarse grid."""
    prof = exact_profile(n)
    g = prof.nodes[::stride, 0].copy()
    m, h = len(g), prof.h * stride
    k = 2 * np.pi * np.fft.rfftfreq(m, d=h)
    hat = np.sinc(k / (2 * np.pi)) ** 2
    for _ in range(2000):
        pos = np.maximum(g, 0.0)
        conv = np.fft.irfft(hat * np.fft.rfft(pos**n + eps * pos**a), n=m)
        new = (g @ g / (g @ conv)) ** (n / (n - 1)) * conv
        if np.max(np.abs(new - g)) < 1e-15:
            break
        g = new
    return new


@pytest.mark.parametrize("n", [1.5, 2.5])
def test_first_order_wave_against_the_perturbed_travelling_wave(n):
    """h = d g / d eps at eps = 0 (central difference of the nonlinear wave), and the speed at fixed peak."""
    a = n + 1
    _, h, _ = first_order_profile(n, sympy.Rational(str(a)))
    e = 1e-4  # the central difference's error is ~70 e^2 for n = 3/2
    diff = (_nonlinear_wave(n, a, e) - _nonlinear_wave(n, a, -e)) / (2 * e)
    S0 = exact_profile(n).S0
    assert np.max(np.abs(diff - h)) < 2e-6 * S0
    # speed at fixed peak: the unit-speed perturbed wave has peak P; the unperturbed wave of that peak has speed
    # (P/S0)^s, so the perturbed one is faster by 1/(P/S0)^s = 1 + speed * eps * (P/S0)^(a-n) + O(eps^2)
    consts = elastic_constants(n)
    s = (n - 1) / 2
    for eps in (0.02, 0.01):
        P = _nonlinear_wave(n, a, eps).max()
        rel = (P / S0) ** -s - 1
        assert rel / (eps * (P / S0) ** (a - n)) == pytest.approx(consts.speed, rel=3 * eps)


@pytest.mark.parametrize("n", NS)
def test_elastic_constants_of_a_stiffness_change(n):
    """c d^n is the stiffness 1 + eps c: the wave is rescaled exactly, mu = (1 + eps)^(-1/(n-1)) at fixed speed, so
    h(0)/S0 = -1/(n-1), and energy conservation gives P'/P0 = (1 + eps)^(-1/(n+1)), speed (1 + eps)^(1/2)."""
    c = elastic_constants(n, a=sympy.Rational(str(n)))
    assert c.h0 == pytest.approx(-1 / (n - 1), abs=1e-9)
    assert c.jump == pytest.approx(-1 / (n + 1), abs=1e-9)
    assert c.speed == pytest.approx(0.5, abs=1e-9)
    assert c.accuracy < 1e-8


def test_elastic_solve_converged_in_grid():
    n, a = 2.0, sympy.Integer(3)
    tau, h, _ = first_order_profile(n, a, stride=16)
    tau2, h2, _ = first_order_profile(n, a)  # twice as fine
    assert np.max(np.abs(h - h2[::2])) < 1e-10 * np.max(np.abs(h))
    assert tau[0] == tau2[0]


def test_taper_law_and_elastic_equations_are_sympy():
    t = taper_law(1.5)
    strain, velocity = t.equations()
    assert isinstance(strain, sympy.Eq) and isinstance(velocity, sympy.Eq)
    assert t.velocity_peak(2 * t.S0, 4.0) == pytest.approx(t.V1 * 2 ** 1.25 / 2, rel=1e-14)
    c = elastic_constants(1.5)
    assert isinstance(c.jump_equation(), sympy.Eq) and isinstance(c.speed_equation(), sympy.Eq)
    with pytest.raises(ContactError, match="a > 0"):
        elastic_constants(1.5, a=0)
    assert isinstance(ContactMonomial(sympy.Integer(1), half, 1).integral, str)
