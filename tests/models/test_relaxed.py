"""Relaxed transfer map (solvers/models/relaxed.py): construction, scaling reuse, cache, refusals."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from pulsemap.symbolic.perturbation import make_perturbation
from pulsemap.symbolic.profile import exact_profile
from pulsemap.symbolic.scaling import monomial_exponents, scaling_exponent
from pulsemap.solvers.models import relaxed_table as rt
from pulsemap.solvers.models.codeload import force_module
from pulsemap.solvers.models.relaxed import RelaxedError, bead_coefficients, build_model, iterate_relaxed

N = 1.5
S0 = exact_profile(N).S0


def model_for(R: str, eps: float, params: dict, beads: int = 80, fp: int = 16):
    pert = make_perturbation(R, eps, params)
    values = {k: (np.asarray(pert.bead_values(k, beads)) if k in pert.site_dependent else float(pert.params[k]))
              for k in pert.used_parameters}
    coef = bead_coefficients(force_module(pert.text, pert.used_parameters), pert.used_parameters, values,
                             eps, fp, beads)
    return build_model(pert.R, pert.text, pert.used_parameters, values, eps, N, coef, first_perturbed=fp)


def test_scaling_exponent_matches_the_symmetry_of_eq1():
    """x -> l x, t -> l^-s t: contact forces scale as l^n, u^a v^b as l^(a + (1+s) b)."""
    for n in (1.5, 2.0, 3.0):
        s = (n - 1) / 2
        for a, b in ((1, 0), (3, 0), (0, 1), (2, 1)):
            assert scaling_exponent(a, b, n) == pytest.approx(a + (1 + s) * b - n)
    assert scaling_exponent(1, 0, 1.5) == -0.5 and scaling_exponent(0, 1, 1.5) == -0.25


def test_monomial_exponents():
    assert monomial_exponents(make_perturbation("alpha*u^3", 0.1, {"alpha": -1}).R) == (3, 0)
    assert monomial_exponents(make_perturbation("-k*u*v^2", 0.1, {"k": 2}).R) == (1, 2)
    assert monomial_exponents(make_perturbation("-(u - mu*(1 - u^2)*v)", 0.1, {"mu": 1}).R) is None
    assert monomial_exponents(make_perturbation("sin(u)", 0.1, {}).R) is None


def test_eps_zero_gives_the_identity_map():
    """R = 0 (eps = 0): onset and bulk ratios are 1 to the DNS accuracy."""
    model = model_for("-(u - mu*(1 - u^2)*v)", 0.0, {"mu": 3.0})
    run = iterate_relaxed(model, 1.2, 15, 30)
    assert run.status == "ok" and list(run.contacts) == list(range(16, 31))
    assert np.max(np.abs(run.peaks / 1.2 - 1.0)) < 1e-6


def test_segment_runs_obey_the_scaling_law():
    """A segment of eps c u at amplitude A has the peaks of -u (eps = 1) at |eps c|^(1/e) A, scaled."""
    eps, alpha, A = 0.2, -1.0, 0.8
    e = scaling_exponent(1, 0, N)
    lam = abs(eps * alpha) ** (1 / e)
    direct = np.array(rt.segment_peaks(rt.SegmentSpec("alpha*u", (("alpha", alpha),), eps, N), A))
    canonical = np.array(rt.segment_peaks(rt.SegmentSpec("-u^1", (), 1.0, N), lam * A))
    k = min(len(direct), len(canonical))
    assert k > rt.ONSET + 3
    assert np.max(np.abs(canonical[:k] / (lam * direct[:k]) - 1.0)) < 1e-6  # DNS rtol 1e-9, accumulated


def test_one_table_serves_every_eps_and_matches_a_direct_run():
    """eps = 0.1 with alpha = -3 and eps = 0.3 with alpha = -1 use the same canonical runs (no new DNS),
    and the model's ratios agree with a direct segment run of R at eps = 0.3."""
    first = model_for("alpha*u", 0.1, {"alpha": -3.0})
    seed = 0.75
    run1 = iterate_relaxed(first, seed, 15, 24)
    used = sum(len(t.runs) for t in first.tables.values())
    assert used > 0

    calls = []
    real = rt.segment_peaks
    rt.segment_peaks = lambda spec, amp: calls.append(amp) or real(spec, amp)
    try:
        second = model_for("alpha*u", 0.3, {"alpha": -1.0})
        run2 = iterate_relaxed(second, seed, 15, 24)
    finally:
        rt.segment_peaks = real
    assert calls == []  # every run came from the cache
    assert np.allclose(run1.peaks, run2.peaks, rtol=1e-12)

    # a direct segment run of alpha*u at eps = 0.3 entering at its own P_0: same ratios
    direct = np.array(rt.segment_peaks(rt.SegmentSpec("alpha*u", (("alpha", -1.0),), 0.3, N), seed / S0))
    check = iterate_relaxed(second, float(direct[0]), 15, 15 + len(direct) - 1)
    pred = np.concatenate([[direct[0]], check.peaks])
    k = min(len(pred), len(direct), 12)
    assert np.max(np.abs(pred[:k] / direct[:k] - 1.0)) < 5e-3


def test_cache_round_trip(monkeypatch):
    spec = rt.SegmentSpec("-u^3", (), 1.0, N)
    first = rt.cached_segment(spec, 0)
    monkeypatch.setattr(rt, "segment_peaks", lambda *a: pytest.fail("the cached run was recomputed"))
    assert rt.cached_segment(spec, 0) == first
    other = rt.SegmentSpec("-u^3", (), 1.0, N, rtol=1e-8)
    assert other.key(0) != spec.key(0) and spec.key(0) != spec.key(1)


def test_bulk_fit_reproduces_a_smooth_law():
    x = np.linspace(-3, 1, 60)
    y = -0.05 * np.exp(-0.5 * x)
    fit = rt.fit_bulk(x, y)
    assert np.max(np.abs(fit(x) - y)) < 1e-4 * np.max(np.abs(y))
    assert rt.fit_bulk(x[:0], y[:0]) is None
    assert float(rt.fit_bulk(np.full(5, 0.3), np.full(5, -0.01))(0.3)) == pytest.approx(-0.01)


def test_site_dependent_r_the_grid_cannot_take_is_refused():
    """Several monomials: one site-dependent parameter, no explicit bead index."""
    with pytest.raises(RelaxedError, match="2 site-dependent parameters"):
        model_for("-(k*u - mu*v)", 0.1, {"k": [0.5] * 80, "mu": [1.0] * 80})
    with pytest.raises(RelaxedError, match="depends on the bead index i"):
        model_for("-(k*i*u - mu*v)", 0.1, {"k": 0.01, "mu": 1.0})


def test_seed_is_checked():
    model = model_for("alpha*u", 0.1, {"alpha": -1.0})
    with pytest.raises(RelaxedError, match="seed_peak"):
        iterate_relaxed(model, math.nan, 15, 30)
    with pytest.raises(RelaxedError, match="after the seed"):
        iterate_relaxed(model, 1.0, 15, 15)


def test_segment_runs_use_the_engine_simulate_chooses(monkeypatch):
    """A polynomial R and a non-smooth one (Coulomb's sign, its ramp through Rodas4) run on the compiled engine."""
    from pulsemap.solvers.chain import dns

    engines = []
    real = dns.simulate

    def spy(*args, **kw):
        res = real(*args, **kw)
        engines.append(res.engine)
        return res

    monkeypatch.setattr(dns, "simulate", spy)
    assert len(rt.segment_peaks(rt.SegmentSpec("-u^1", (), 1.0, N), 1.0)) > rt.ONSET
    assert len(rt.segment_peaks(rt.SegmentSpec("-mu*sign(v)", (("mu", 1.0),), 0.05, N), 1.0)) > rt.ONSET
    assert engines == ["compiled", "compiled"]


def test_a_segment_run_that_stops_early_is_an_error_not_a_dead_pulse(monkeypatch):
    """A run stopped by its step budget (as by an integrator failure) raises with its reason."""
    from pulsemap.solvers.chain import dns

    real = dns.simulate
    monkeypatch.setattr(dns, "simulate", lambda *a, **kw: real(*a, **{**kw, "stop": replace(kw["stop"], max_steps=20)}))
    with pytest.raises(rt.SegmentRunError, match="ended early: step budget of 20 steps"):
        rt.segment_peaks(rt.SegmentSpec("-u^1", (), 1.0, N), 1.0)


def test_a_dying_step_is_read_within_one_lattice_spacing_below_the_bulk_points():
    """Where the low end is closed (runs there die before they relax), the map reaches DYING_REACH below its
    lowest point and no further; not where the end is open, nor where the runs blow up."""
    spec = rt.SegmentSpec("-mu*sign(v)", (("mu", 1.0),), 0.02, N)
    dying = [0.9 ** k for k in range(rt.ONSET + 6)] + [0.3]  # the last step before death: a steep drop
    tab = rt.SegmentTable(spec, runs={0: dying, -1: [0.5, 0.2]}, closed={"low"})
    low = tab.bulk_range()[0]
    assert low == pytest.approx(math.log(dying[-2]))
    assert tab.dying_step(low - 0.9 * rt.DYING_REACH) and tab.cover(low - 0.9 * rt.DYING_REACH)
    assert not tab.dying_step(low - 1.1 * rt.DYING_REACH) and not tab.cover(low - 1.1 * rt.DYING_REACH)
    assert not rt.SegmentTable(spec, runs=dict(tab.runs)).dying_step(low - 0.5 * rt.DYING_REACH)
    growing = rt.SegmentTable(spec, runs={0: [1.1 ** k for k in range(rt.ONSET + 6)]}, closed={"low"})
    assert not growing.dying_step(growing.bulk_range()[0] - 0.5 * rt.DYING_REACH)
