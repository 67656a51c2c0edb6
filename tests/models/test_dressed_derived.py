"""Dressed coefficients derived by the expansion about the exact wave, checked against independent methods:
the energy balance (k1), the nonlinear DNS of a launched soliton (the O(c^2) peaks), and the DNS
calibration (k2/k1, onset lag, cross terms)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pulsemap.symbolic.profile import exact_profile
from pulsemap.solvers.chain.equations import OnSiteForce
from pulsemap.solvers.chain.launch import launch, min_centre
from pulsemap.solvers.models import dressed_expansion as dd
from pulsemap.solvers.models.dressed_expansion import ExpansionError, expansion_orbits
from pulsemap.solvers.studies import dressed_calibration as dc


def test_geometric_limit_is_exact_on_a_geometric_sequence_and_flags_the_rest():
    seq = 2.0 + 0.3 * 0.4 ** np.arange(6)
    value, err = dd.geometric_limit(seq)
    assert value == pytest.approx(2.0, abs=1e-13) and err == pytest.approx(0.3 * 0.4**5, rel=1e-9)  # the tail beyond the last term
    value, err = dd.geometric_limit(np.array([1.0, 2.0, 3.0]))  # not converging: no extrapolation, error = steps
    assert value == 3.0 and err == 2.0


def test_first_order_of_the_expansion_is_the_energy_balance():
    """k1 from the time-domain first order (contacts relax geometrically) against -w_01/((n+1) E_1) (mpmath)."""
    _, alpha, _, _ = expansion_orbits(((0, 1),), (), 1.5, cut=1e-3, settle=10, span=4, rtol=1e-10)  # first order only
    k1, err = dd.geometric_limit(-np.diff(alpha[0]))
    assert abs(k1 - dd.first_order_rate(0, 1, 1.5)) < max(3 * err, 1e-8)
    assert abs(k1 - dd.first_order_rate(0, 1, 1.5)) < 1e-5


def _launched_peaks(a: int, b: int, c: float, first: int, last: int, more=()) -> np.ndarray:
    """Peaks of contacts first-1..last of an exact soliton (A0 = 1) with R = c u^a v^b (+ c' u^a' v^b' for
    (a', b', c') in ``more``) on beads >= first."""
    centre = min_centre(1.5) + 1
    beads = last + min_centre(1.5) + 4
    mask = np.zeros(beads)
    mask[first - 1:] = 1.0
    terms = ((a, b, c),) + tuple(more)
    force = OnSiteForce(force=lambda x, v: mask * sum(cc * x**aa * v**bb for aa, bb, cc in terms))
    res = launch(beads, 1.5, 1.0, centre, (first - 1, last), force, rtol=1e-12, atol=1e-15)
    return np.array(res.peaks, dtype=float)


@pytest.mark.slow
@pytest.mark.parametrize("a, b, cs, first_ratio, second_ratio", [
    (0, 1, (0.02, 0.01), (3.5, 4.5), (5.0, 11.0)),  # damping: analytic, the remainder is O(c^3)
    (1, 0, (-0.004, -0.002), (3.5, 4.5), (5.0, 7.0)),  # foundation: O(|c|^(5/2)), the |x|^(3/2) term
])
def test_expansion_peaks_match_the_nonlinear_chain(a, b, cs, first_ratio, second_ratio):
    """ln P_k of the nonlinear DNS (R = c u^a v^b, exact soliton launched) minus the expansion's
    ln S0 + c alpha_k (+ c^2 beta_k): halving c divides the first-order remainder by 4 and the second-order
    one by 8 (damping) or 2^(5/2) = 5.7 (a foundation's non-analytic next term); the second-order remainder
    is far below c^2 beta."""
    ks, alpha, beta, first = expansion_orbits(((a, b),), ((0, 0),), 1.5, cut=1e-6, settle=4, span=4, rtol=1e-10)
    S0 = exact_profile(1.5).S0
    one, two = [], []
    for c in cs:
        lnP = np.log(_launched_peaks(a, b, c, first, int(ks[-1])))
        one.append(np.abs(lnP - (math.log(S0) + c * alpha[0])).max())
        two.append(np.abs(lnP - (math.log(S0) + c * alpha[0] + c**2 * beta[0])).max())
        assert two[-1] < 0.2 * c**2 * np.abs(beta[0]).max()
    assert first_ratio[0] < one[0] / one[1] < first_ratio[1]
    assert second_ratio[0] < two[0] / two[1] < second_ratio[1]


@pytest.mark.slow
def test_mixed_second_order_matches_the_nonlinear_chain():
    """R = c_1 u + c_2 v: the expansion with both first orders, both squares and the mixed term (the cross
    coefficient's source) against the DNS; halving both c divides the remainder by ~2^(5/2) (the foundation)."""
    mons, pairs = ((1, 0), (0, 1)), ((0, 0), (0, 1), (1, 1))
    ks, alpha, beta, first = expansion_orbits(mons, pairs, 1.5, cut=1e-6, settle=4, span=4, rtol=1e-10)
    S0 = exact_profile(1.5).S0
    rem, mixed = [], []
    for c1, c2 in ((-0.004, -0.004), (-0.002, -0.002)):
        lnP = np.log(_launched_peaks(1, 0, c1, first, int(ks[-1]), more=((0, 1, c2),)))
        model = math.log(S0) + c1 * alpha[0] + c2 * alpha[1] + c1**2 * beta[0] + c2**2 * beta[2]
        rem.append(np.abs(lnP - model - c1 * c2 * beta[1]).max())
        mixed.append(np.abs(c1 * c2 * beta[1]).max())
        assert rem[-1] < 0.2 * mixed[-1]  # the mixed term is needed and explains the rest
    assert 4.5 < rem[0] / rem[1] < 7.5


def test_shipped_derived_coefficients_agree_with_the_shipped_calibration():
    """Both tables shipped with pulsemap, produced by independent methods (expansion vs DNS fits)."""
    for a, b in ((0, 1), (2, 1), (1, 0), (3, 0)):
        d, f = dd.derive_monomial(a, b, 1.5), dc.calibrate(a, b, 1.5)
        assert d.k1 == pytest.approx(f.k1, rel=1e-7)
        assert abs(d.k2_over_k1 - f.k2_over_k1) < d.k2_over_k1_error + f.k2_over_k1_error, (a, b)
        assert abs(d.onset_lag - f.onset_lag) < d.onset_lag_error + f.onset_lag_error, (a, b)


def test_bad_monomials_are_refused():
    with pytest.raises(ExpansionError, match="integer >= 0"):
        dd.derive_monomial(-1, 1)
    with pytest.raises(ExpansionError, match="constant monomial"):
        dd.derive_monomial(0, 0)


@pytest.mark.slow
@pytest.mark.parametrize("a,b", [(0, 1), (2, 1), (1, 0), (3, 0)])
def test_derived_coefficients_agree_with_a_fresh_dns_calibration(a, b):
    """No cache on either side: k2/k1 and the onset lag within the sum of the stated errors."""
    d, f = dd.derive_monomial(a, b, 1.5, use_cache=False), dc.calibrate(a, b, 1.5, use_cache=False)
    assert abs(d.k2_over_k1 - f.k2_over_k1) < d.k2_over_k1_error + f.k2_over_k1_error
    assert abs(d.onset_lag - f.onset_lag) < d.onset_lag_error + f.onset_lag_error
    assert d.k1 == pytest.approx(dd.first_order_rate(a, b, 1.5), rel=1e-7)


@pytest.mark.slow
def test_derived_cross_term_agrees_with_a_fresh_dns_calibration():
    d = dd.derive_cross((1, 0), (0, 1), 1.5, use_cache=False)
    f = dc.calibrate_cross((1, 0), (0, 1), 1.5, use_cache=False)
    assert abs(d.k2 - f.k2) < d.error + f.error


@pytest.mark.parametrize("a, b", [(0, 1), (1, 0)])
def test_derived_agrees_with_a_fresh_dns_calibration_at_n2(a, b):
    """n = 2: F'' is constant (no cut to extrapolate) and both sides take seconds; no cache on either side."""
    d, f = dd.derive_monomial(a, b, 2.0, use_cache=False), dc.calibrate(a, b, 2.0, use_cache=False)
    assert d.k1 == pytest.approx(dd.first_order_rate(a, b, 2.0), rel=1e-8)
    assert abs(d.cut_extrapolation) < 1e-9 and d.k2_over_k1_error < 1e-4
    assert abs(d.k2_over_k1 - f.k2_over_k1) < d.k2_over_k1_error + f.k2_over_k1_error
    assert abs(d.onset_lag - f.onset_lag) < d.onset_lag_error + f.onset_lag_error
