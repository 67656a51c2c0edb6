"""The contact energy law, the taper law and the elastic entry jump against a small direct simulation of the chain
m_i x_i'' = F(d_(i-1), w_(i-1)) - F(d_i, w_i), F = H(d) (d^n + eps P(d, w)), launched with the exact wave."""

from __future__ import annotations

import numpy as np
import pytest
import sympy

from pulsemap.solvers.models.contact_law import ContactLawError, contact_law_peaks
from pulsemap.symbolic.contact import amplitude_terms, contact_monomials, derive_contact
from pulsemap.symbolic.contact_wave import elastic_constants, taper_law
from pulsemap.symbolic.profile import exact_profile

d, w, gamma = sympy.symbols("d w gamma", real=True)


def _dns(n, beads, masses, P, eps, first, t_end, launch=6):
    """Strain and bead-velocity peaks of a chain launched with the unit-mass exact wave (A = 1) at contact
    ``launch``; the contact term eps P(d, w) acts on contacts >= ``first``."""
    from scipy.integrate import solve_ivp

    prof = exact_profile(n)
    m = np.asarray(masses, dtype=float)
    k = np.arange(beads)
    strain = prof.S(-(k[:-1] - launch))
    x = np.append(np.cumsum(strain[::-1])[::-1], 0.0)
    v = np.append(np.cumsum(prof.dS(-(k[:-1] - launch))[::-1])[::-1], 0.0) / np.sqrt(m)
    on = (k[:-1] >= first).astype(float)

    def rhs(_t, y):
        dd, ww = y[: beads - 1] - y[1:beads], y[beads:-1] - y[beads + 1:]
        pos = np.maximum(dd, 0.0)
        F = np.where(dd > 0, pos**n + eps * on * P(pos, ww), 0.0)
        acc = (np.append(0.0, F) - np.append(F, 0.0)) / m
        return np.concatenate([y[beads:], acc])

    sol = solve_ivp(rhs, (0, t_end), np.concatenate([x, v]), method="DOP853", rtol=1e-10, atol=1e-12,
                    dense_output=True)
    t = np.linspace(0, t_end, int(t_end * 40) + 1)
    y = sol.sol(t)
    return _peaks(y[: beads - 1] - y[1:beads], t), _peaks(y[beads:], t)


def _peaks(series, t):
    """Each row's maximum over time, refined by a parabola through the largest sample and its neighbours."""
    j = np.clip(np.argmax(series, axis=1), 1, len(t) - 2)
    r = np.arange(series.shape[0])
    y0, y1, y2 = series[r, j - 1], series[r, j], series[r, j + 1]
    den = y0 - 2 * y1 + y2
    return y1 - 0.125 * (y2 - y0) ** 2 / np.where(den == 0, -1.0, den)


def _rate(peaks, span=slice(16, 39)):
    """The mean change of P^(1/4) per contact: the dashpot law at n = 3/2 makes it a constant."""
    return float(np.mean(np.diff(np.asarray(peaks, dtype=float)[span] ** 0.25)))


def test_dashpot_law_against_dns():
    """Dashpot c w on contacts >= 12, n = 3/2: the law's decay rate is the DNS's to first order in eps (the
    DNS's relative departure halves with eps and extrapolates to zero), masses 2 carry the factor m^(-1/2)."""
    beads, mono = 46, contact_monomials(w)
    misses = {}
    for eps in (0.01, 0.005):
        peaks = _dns(1.5, beads, np.ones(beads), lambda dd, ww: ww, eps, 12, 40.0)[0]
        law = contact_law_peaks(mono, 1.5, eps, float(peaks[16]), 16, 38)
        misses[eps] = _rate(peaks) / _rate(law.peaks, slice(0, None)) - 1
    assert 0.01 < abs(misses[0.01]) < 0.06  # first-order law: an O(eps) departure
    assert abs(2 * misses[0.005] - misses[0.01]) < 0.2 * abs(misses[0.01])  # ... that extrapolates to ~0
    eps, mass = 0.005, 2.0
    peaks = _dns(1.5, beads, np.full(beads, mass), lambda dd, ww: ww, eps, 12, 40.0 * np.sqrt(mass))[0]
    heavy = contact_law_peaks(mono, 1.5, eps, float(peaks[16]), 16, 38, masses=np.full(40, mass))
    unit = contact_law_peaks(mono, 1.5, eps, float(peaks[16]), 16, 38)
    assert abs(_rate(peaks) / _rate(heavy.peaks, slice(0, None)) - 1) < 1.5 * abs(misses[eps])
    assert abs(_rate(peaks) / _rate(unit.peaks, slice(0, None)) - 1) > 0.25  # 1 - 2^(-1/2)


def test_uniform_law_matches_the_closed_form():
    """Per-contact values that are all equal give the sympy closed form (derive) at every contact."""
    mono = contact_monomials(gamma * sympy.sqrt(d) * w)
    law = derive_contact(mono, 2.0, 0.03, params={"gamma": 0.8}).law
    run = contact_law_peaks(mono, 2.0, 0.03, 1.1, 3, 60, params={"gamma": np.full(61, 0.8)})
    S0 = exact_profile(2.0).S0
    f = sympy.lambdify(sympy.Symbol("i", real=True),
                       law.numeric_law().subs({sympy.Symbol("A_0", positive=True): 1.1 / S0,
                                               sympy.Symbol("i_0", real=True): 3}))
    assert np.allclose(run.A, [f(k) for k in run.contacts], rtol=1e-9, atol=0)


def test_map_form_steps_the_energy():
    """The map: E_1 (A_k^(n+1) - A_(k-1)^(n+1)) is the work at A_(k-1); it follows the law to O(rate^2) per step."""
    mono = contact_monomials(sympy.sqrt(d) * w)
    law = contact_law_peaks(mono, 2.5, 0.02, 1.2, 0, 40)
    step = contact_law_peaks(mono, 2.5, 0.02, 1.2, 0, 40, form="map")
    A, B = np.array(step.A), np.array(law.A)
    assert step.form == "map" and law.form == "law"
    q = float(mono[0].q(2.5))
    energy_step = np.diff(A**3.5) / (3.5 * A[:-1] ** (q + 2.5))
    assert np.allclose(energy_step, energy_step[0], rtol=1e-12)
    # Euler steps in the energy: a departure of the order of the step's rate (~1 %) of the total change
    assert 1e-6 < np.max(np.abs(A - B)) < 0.03 * (B[0] - B[-1])


def test_parameter_varying_along_the_chain():
    """A per-contact gamma that is zero on the first half: no change there, decay after."""
    mono = contact_monomials(gamma * w)
    g = np.where(np.arange(41) < 20, 0.0, 1.0)
    run = contact_law_peaks(mono, 1.5, 0.02, 1.0, 0, 40, params={"gamma": g})
    peaks = np.array(run.peaks)
    assert np.all(peaks[:20] == 1.0)
    assert np.all(np.diff(peaks[20:]) < 0)


def test_extra_terms_add_an_onsite_law():
    """An on-site energy law (-v) with the same power adds its rate: dashpot eps 0.01 + on-site eps 0.01."""
    from pulsemap.symbolic.balance import derive_balance
    from pulsemap.symbolic.perturbation import make_perturbation

    onsite = derive_balance(make_perturbation("-v", eps=0.01), "energy", n=1.5)
    extra = amplitude_terms(onsite.law)
    run = contact_law_peaks(contact_monomials(w), 1.5, 0.01, 1.0, 0, 30, extra_terms=extra)
    both = contact_law_peaks(contact_monomials(w), 1.5, 0.01, 1.0, 0, 30)
    only = contact_law_peaks((), 1.5, 0.0, 1.0, 0, 30, extra_terms=extra)
    A = lambda r: np.array(r.A)  # noqa: E731
    # A^(1/4) falls linearly in each, at the sum of the two rates together
    assert np.allclose(np.diff(A(run) ** 0.25), np.diff(A(both) ** 0.25) + np.diff(A(only) ** 0.25), rtol=1e-8)


def test_taper_against_dns():
    """Masses 1 + slope (i - 12) on beads >= 12: the strain peak stays and bead velocities go as m^(-1/2), up to
    O(slope) departures (the kink at bead 12) that halve with the slope."""
    beads, span, law = 46, slice(10, 38), taper_law(1.5)
    departures = []
    for slope in (0.01, 0.005):
        m = 1 + slope * np.maximum(np.arange(beads) - 12, 0)
        strain, speed = _dns(1.5, beads, m, lambda dd, ww: 0 * dd, 0.0, 0, 48.0)
        predicted = np.array([law.velocity_peak(strain[10], mi) for mi in m[span]])
        departures.append((np.max(np.abs(strain[span] / strain[10] - 1)), np.max(np.abs(speed[span] / predicted - 1))))
        assert speed[span][-1] / speed[span][0] < 1 - slope * 10  # the m^(-1/2) trend is what is being checked
    assert max(departures[0]) < 1e-2  # m grows by 26 %
    assert all(b < 0.6 * a for a, b in zip(*departures))


def test_elastic_entry_jump_against_dns():
    """c d^(n+1) from contact 14 on: the transmitted plateau's peak ratio, extrapolated to first order in eps, is J;
    the law seeded before the correction puts the plateau where the DNS has it."""
    n, beads = 1.5, 44
    jump = elastic_constants(n).jump
    mono = contact_monomials(gamma * d ** sympy.Rational(5, 2))
    slopes = []
    for eps in (0.04, 0.02):
        peaks = _dns(n, beads, np.ones(beads), lambda dd, ww: dd ** (n + 1), eps, 14, 38.0)[0]
        A0 = np.mean(peaks[6:12]) / exact_profile(n).S0
        ratio = np.mean(peaks[26:34]) / np.mean(peaks[6:12])
        slopes.append((ratio - 1) / (eps * A0))
        law = contact_law_peaks(mono, n, eps, float(peaks[8]), 8, 34, params={"gamma": (np.arange(35) >= 14) * 1.0})
        assert np.max(np.abs(np.array(law.peaks[18:]) / peaks[26:35] - 1)) < 0.4 * eps**2
        assert abs(law.peaks[-1] / law.peaks[0] - 1) > 0.15 * eps  # the jump itself is what is compared
    first_order = 2 * slopes[1] - slopes[0]  # Richardson: the O(eps) error cancels
    assert first_order == pytest.approx(jump, rel=0.01)
    assert abs(slopes[1] - jump) < abs(slopes[0] - jump)  # converging as eps -> 0


def test_bad_input():
    mono = contact_monomials(gamma * w)
    with pytest.raises(ContactLawError, match="needs a value for gamma"):
        contact_law_peaks(mono, 1.5, 0.01, 1.0, 0, 10)
    with pytest.raises(ContactLawError, match="give a longer list"):
        contact_law_peaks(mono, 1.5, 0.01, 1.0, 0, 10, params={"gamma": [1.0] * 5})
    with pytest.raises(ContactLawError, match="masses must be finite and > 0"):
        contact_law_peaks(mono, 1.5, 0.01, 1.0, 0, 10, params={"gamma": 1.0}, masses=[1.0] * 5 + [0.0] * 7)
    with pytest.raises(ContactLawError, match="not finite at contact 3"):
        contact_law_peaks(contact_monomials(w / gamma), 1.5, 0.01, 1.0, 0, 10, params={"gamma": [1, 1, 1, 0] + [1] * 7})
    with pytest.raises(ContactLawError, match="choose law or map"):
        contact_law_peaks(mono, 1.5, 0.01, 1.0, 0, 10, params={"gamma": 1.0}, form="steps")
    with pytest.raises(ContactLawError, match="seed peak"):
        contact_law_peaks(mono, 1.5, 0.01, float("nan"), 0, 10, params={"gamma": 1.0})
