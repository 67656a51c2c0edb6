"""The dressed law: calibrated coefficients reproduced; derived and calibrated laws checked on held-out DNS runs,
in run and derive."""

import json
import math

import numpy as np
import pytest
import sympy

from pulsemap.symbolic import cache
from pulsemap.symbolic.profile import exact_profile
from pulsemap.solvers.chain.equations import OnSiteForce
from pulsemap.solvers.chain.launch import launch, min_centre
from pulsemap.solvers.studies import dressed_calibration as dc
from pulsemap.solvers.data.scene import with_overrides


def test_shipped_calibration_is_reproduced_and_k1_is_the_energy_balance():
    fit = dc.calibrate(0, 1, 1.5, use_cache=False)
    shipped = cache.shipped_table(dc.SHIPPED)[dc.cache_key(0, 1, 1.5)]
    # the DNS behind the fit is integrated at rtol ~1e-10 and its last digits move with the scipy/numpy
    # build; the fit's own uncertainty (k2_over_k1_error) is four orders larger than this tolerance
    assert fit.k2_over_k1 == pytest.approx(shipped["k2_over_k1"], rel=1e-6)
    assert fit.onset_lag == pytest.approx(shipped["onset_lag"], rel=1e-6)
    # damping: k1 = -(2/5) 2 K1/E1 = -4/9 (virial theorem K1/E1 = 5/9)
    assert fit.k1 == pytest.approx(-4 / 9, rel=1e-10)
    assert fit.k2_over_k1_error < 1e-4 and fit.fit_rms < 1e-5


def _held_out(a, b, x0, contacts=40):
    """Peaks of a launched soliton (A0 = 1) with R = x0 u^a v^b from bead first on, as in the calibration."""
    centre = min_centre(1.5) + 1
    first = centre + 8
    last = first + dc.SETTLE + contacts
    beads = last + 6
    mask = np.zeros(beads)
    mask[first - 1:] = 1.0
    res = launch(beads, 1.5, 1.0, centre, (first - 1, last), OnSiteForce(force=lambda x, v: mask * x0 * x**a * v**b))
    return first, np.array(res.contacts), np.array(res.peaks, float) / exact_profile(1.5).S0


@pytest.mark.parametrize("a, b, x0", [(0, 1, -0.003), (0, 1, -0.02), (2, 1, -0.003)])
def test_dressed_law_predicts_a_held_out_launch(a, b, x0):
    """A value of c not on the calibration ladder (one beyond it): the dressed law, started at the seed
    contact with its onset lag, follows the DNS far better than the energy law."""
    from pulsemap.solvers.models.dressed_expansion import derive_monomial

    fit = dc.calibrate(a, b, 1.5)
    derived = derive_monomial(a, b, 1.5)
    first, contacts, A = _held_out(a, b, x0)

    def law(i_end, rho, lag):
        lnA = math.log(A[0])
        x = x0 * A[0] ** fit.e
        lnA += lag * fit.k1 * x / (1 - rho * x)
        out = [lnA]
        for _ in contacts[1:]:  # RK4 in i, step 1/8
            for _ in range(8):
                f = lambda l: -fit.k1 * x0 * math.exp(l * fit.e) / (1 - rho * x0 * math.exp(l * fit.e))  # noqa: E731
                k1_ = f(lnA); k2_ = f(lnA + k1_ / 16); k3_ = f(lnA + k2_ / 16); k4_ = f(lnA + k3_ / 8)
                lnA += (k1_ + 2 * k2_ + 2 * k3_ + k4_) / 48
            out.append(lnA)
        return np.array(out)

    tail = contacts >= first + dc.SETTLE
    energy = np.abs(law(contacts[-1], 0.0, 0.0) - np.log(A))[tail].max()
    for rho, lag in ((fit.k2_over_k1, fit.onset_lag), (derived.k2_over_k1, derived.onset_lag)):
        dressed = np.abs(law(contacts[-1], rho, lag) - np.log(A))[tail].max()
        assert dressed < energy / 20
        assert dressed < 2e-3 * abs(x0) / 0.003 * abs(x0) / 0.003 + 1e-6


def test_dressed_law_beats_the_energy_law_on_damping():
    """fig8-eps0.1 (R = -mu v, eps 0.1), contacts 16-60 from the kicked pulse: measured RMS 0.6 % (dressed)
    against 32 % (energy law) over the whole live range."""
    from pulsemap.solvers.data.scene import load_scene
    from pulsemap.solvers.studies.run import run_scene

    res = run_scene(with_overrides(load_scene("fig8-eps0.1"), contacts=(16, 60)), methods=["dns", "energy-law", "dressed-law"])
    d, e = res["errors"]["dressed-law"]["rms_pct"], res["errors"]["energy-law"]["rms_pct"]
    assert d < 1 and d < e / 10
    info = res["dressed-law"]
    assert info["coefficients"]["v"]["k1"] == pytest.approx(-4 / 9, rel=1e-10)
    assert {"v:k2_over_k1", "v:onset_lag"} <= set(info["derived"]) and not info["calibrated"]


def test_dressed_law_follows_a_graded_foundation_and_refuses_the_pade_profile():
    """k = 1 + (i - 16)/50, eps = 0.01, contacts 16-120: c_j(i) along the chain (bead i + 1/2). Measured
    against the DNS over the contacts it gives (16-87; quiet past them, its estimated error passing 5 %):
    dressed RMS 0.27 %, max 0.92 %; energy law RMS 11.3 % over 16-120."""
    from pulsemap.solvers.data.scene import parse_scene
    from pulsemap.solvers.studies.run import run_scene

    sc = parse_scene({"name": "t", "chain": {"exponent": 1.5, "first_perturbed": 16, "beads": 130},
                      "excitation": {"velocity": 1.0},
                      "perturbation": {"R": "-k*u", "eps": 0.01, "params": {"k": "1 + (i - 16)/50"}},
                      "output": {"contacts": [16, 120], "methods": ["dressed-law", "energy-law", "dns"]}}, "t")
    res = run_scene(sc)
    pairs = [(q, d) for q, d in zip(res["peaks"]["dressed-law"], res["peaks"]["dns"]) if q is not None and d is not None]
    d = 100 * float(np.sqrt(np.mean([(q / p - 1) ** 2 for q, p in pairs])))
    e = res["errors"]["energy-law"]["rms_pct"]
    assert len(pairs) > 40 and d < e / 2 and d < 5
    res = run_scene(sc, methods=["dressed-law"], profile="pade")
    assert "exact profile" in res["dressed-law"]["refused"]
    assert res["peaks"]["dressed-law"] is None


def test_derive_model_dressed_cli(tmp_path, capsys):
    from pulsemap.solvers.cli.main import main

    out = tmp_path / "d.json"
    assert main(["derive", "-(u - mu*(1-u^2)*v)", "--param", "mu=3", "--eps", "0.1", "--model", "dressed",
                 "--A0", "0.5", "--i0", "15", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "k2/k1" in text and "derived (" in text and "Validity" in text
    data = json.loads(out.read_text())
    assert data["model"] == "dressed"
    mons = data["dressed"]["monomials"]
    assert set(mons) == {"u", "v", "u**2*v"}
    for m in mons.values():
        assert {"k1", "k2_over_k1", "onset_lag"} <= set(m) and m["k1_method"].startswith("derived")
        assert m["k2_method"].startswith("derived (") and m["onset_lag_method"].startswith("derived (")
    assert len(data["dressed"]["cross"]) == 3 and all(c["k2"] is not None for c in data["dressed"]["cross"])
    assert all(c["method"].startswith("derived (") for c in data["dressed"]["cross"])
    # a site-dependent R: the law carries c(i) (bead i + 1/2), no closed form, k2/k1 as for the uniform R
    site = tmp_path / "s.json"
    assert main(["derive", "-k*u", "--param", "k=1 + i/50", "--model", "dressed", "--eps", "0.01", "--i0", "15",
                 "--json", str(site)]) == 0
    text = capsys.readouterr().out
    assert "c(i) = " in text and "numerical integration" in text
    u = json.loads(site.read_text())["dressed"]["monomials"]["u"]
    i = sympy.Symbol("i", real=True)
    assert float(sympy.sympify(u["c_of_i"], locals={"i": i}).subs(i, 15)) == pytest.approx(-0.01 * (1 + 15.5 / 50))
    assert u["c"] == pytest.approx(-0.01 * (1 + 15.5 / 50)) and u["k2_method"].startswith("derived (")
    assert json.loads(site.read_text())["dressed"]["closed_form_i_of_A"] is None
    assert main(["derive", "-sin(u)", "--model", "dressed"]) == 2
    assert "polynomial" in capsys.readouterr().err
    assert main(["derive", "-v", "--model", "dressed", "--profile", "pade"]) == 2
    assert main(["derive", "-v", "--coefficients", "calibrated"]) == 2
    assert "--coefficients applies to the dressed law only" in capsys.readouterr().err


def test_api_dressed():
    import pulsemap

    d = pulsemap.dressed("-mu*v", mu=1, eps=0.1, A0=0.5, i0=15)
    (t,) = d.law.terms
    assert t.c == pytest.approx(-0.1) and t.k1 == pytest.approx(-4 / 9, rel=1e-10)
    assert d.to_dict()["dressed"]["monomials"]["v"]["k2_over_k1"] == t.rho
    assert "onset" in d.to_dict()["dressed"] and "Validity" in str(d)
    with pytest.raises(ValueError, match="polynomial"):
        pulsemap.dressed("-sin(u)")
    with pytest.raises(TypeError, match="R must be"):
        pulsemap.dressed(3)
    assert t.rho_method.startswith("derived (") and t.lag_method.startswith("derived (")
    cal = pulsemap.dressed("-mu*v", mu=1, eps=0.1, coefficients="calibrated").law.terms[0]
    assert cal.rho_method.startswith("calibrated") and cal.k1 == t.k1
    assert abs(cal.rho - t.rho) < cal.rho_error + t.rho_error  # two methods, one coefficient
    with pytest.raises(ValueError, match="coefficients must be"):
        pulsemap.dressed("-mu*v", mu=1, coefficients="fitted")


def test_site_coefficients_along_a_grid_equal_the_pointwise_ones():
    """coefficient_along (one lambdified evaluation over the grid) against coefficient_at (sympy
    substitution per bead position) on a random foundation: the same numbers."""
    from pulsemap.symbolic.balance import balance_expand
    from pulsemap.solvers.data.scene import load_scene
    from pulsemap.solvers.studies.dressed import coefficient_along, coefficient_at

    pert = load_scene("fig13-seed2").perturbation
    grid = np.arange(14.0, 30.0, 1 / 16) + 0.5
    for term in balance_expand(pert.R, 1.5, "energy", pert.site_dependent).terms:
        pointwise = np.array([coefficient_at(term.coefficient, pert, g) for g in grid])
        assert np.ptp(pointwise) > 0  # site-dependent indeed
        np.testing.assert_allclose(coefficient_along(term.coefficient, pert, grid), pointwise, rtol=1e-15, atol=0)


def _foundation(k: str, eps: float, methods: list[str]):
    from pulsemap.solvers.data.scene import parse_scene

    return parse_scene({"name": "t", "chain": {"exponent": 1.5, "first_perturbed": 16, "beads": 140},
                        "excitation": {"velocity": 1.0},
                        "perturbation": {"R": "-k*u", "eps": eps, "params": {"k": k}},
                        "output": {"contacts": [16, 120], "methods": methods}}, "t")


def test_dressed_law_refuses_a_coefficient_that_jumps_from_bead_to_bead():
    """A random foundation: no values, and one line saying why."""
    from pulsemap.solvers.studies.run import run_scene

    res = run_scene(_foundation({"uniform": [0, 0.2], "seed": 1}, 1.0, ["dressed-law"]))
    why = res["dressed-law"]["refused"]
    assert "from one bead to the next" in why and "\n" not in why
    assert res["peaks"]["dressed-law"] is None


def test_dressed_law_cut_follows_its_estimate_not_its_validity_bound():
    """k rising from 0.1 to 1 at eps 0.1: the law passes its calibrated validity bound inside the range (reported,
    a warning); the values it gives are those whose measured-and-carried estimate stays within 5 %, each within its
    estimate of the DNS, the message one line."""
    from pulsemap.solvers.models.dressed import ACCURACY
    from pulsemap.solvers.studies.run import run_scene

    res = run_scene(_foundation("0.1 + 0.00865*(i - 16)", 0.1, ["dressed-law", "dns"]))
    info = res["dressed-law"]
    assert 20 < info["beyond_validity_at"] < 120 and "\n" not in info["message"]
    given = [(p, d, a) for p, d, a in zip(res["peaks"]["dressed-law"], res["peaks"]["dns"], info["accuracy"])
             if p is not None and d is not None]
    assert len(given) > 10
    assert all(a <= ACCURACY and abs(p / d - 1) <= a for p, d, a in given)


def test_rate_residual_is_the_true_rate_minus_the_law_rate_along_the_true_path():
    """A law with rate -k x, x = c A^e, and a true path decaying at the constant rate g per contact: the residual
    is g minus the law's rate averaged along that path (here by its closed form), not the law integrated from the
    window's start (which drifts away from the path)."""
    from pulsemap.solvers.models.dressed import DressedCoefficients
    from pulsemap.solvers.studies.run.dressed import rate_residual

    c, e, k1 = -0.1, -0.25, -4 / 9
    coef = DressedCoefficients((c,), (e,), (k1,), (0.0,), (0.0,), (math.inf,))
    g, lnA0 = -0.05, math.log(0.4)
    lnA = [lnA0 + g * k for k in range(5)]
    mean = -k1 * c * math.exp(e * lnA0) * math.expm1(e * g * 4) / (e * g * 4)  # (1/4) int_0^4 rate(A(i)) di
    assert rate_residual(coef, lnA, [0.0] * 5) == pytest.approx(g - mean, abs=2e-6)  # trapezoid's error
    assert rate_residual(coef, lnA, [0.0] * 5) == pytest.approx(g - mean, rel=1e-3)


def test_the_estimate_holds_where_the_old_one_understated_the_error():
    """R = -u^2 at eps 0.05 (a monomial no constant was set on): the law's error grows to ~4 % along the chain,
    where the former estimate (onset relaxing, calibrated next terms) shrank to 0.02 %. Every value given is
    within its printed estimate, past the measured seed segment included, and none is more than 5 % off."""
    import pulsemap
    from pulsemap.solvers.studies.run.dressed import SEED_SPAN

    res = pulsemap.run(pulsemap.scene("fig6-eps0.1", **{"perturbation.R": "-u^2", "perturbation.eps": 0.05,
                                                         "output.contacts": [16, 45]}),
                       methods=["dns", "dressed-law"]).to_dict()
    rows = [(c, q / d - 1, a) for c, d, q, a in zip(res["contacts"], res["peaks"]["dns"], res["peaks"]["dressed-law"],
                                                   res["dressed-law"]["accuracy"]) if q is not None and d is not None]
    past = [r for r in rows if r[0] > 15 + SEED_SPAN]
    assert len(past) >= 8 and max(abs(e) for _, e, _ in past) > 0.03  # the error that grows is there
    assert all(abs(e) <= a <= 0.05 for _, e, a in rows)


ACCURACY_SCENES = [  # no constant of the estimate was set on any of them
    ("fig8-eps0.1", {}),  # uniform damping
    ("fig8-eps0.3", {}),
    ("fig6-eps0.1", {}),  # uniform linear foundation
    ("fig8-eps0.1", {"excitation.velocity": 5.0}),
    ("fig8-eps0.1", {"perturbation.R": "-(u + u^3 + v)", "perturbation.eps": 0.2}),  # mixed
    ("fig8-eps0.1", {"perturbation.R": "u + u^3 + v", "perturbation.eps": 0.2}),
    ("vdp-mu3-v2.3", {}),
    ("vdp-mu3-v2.3", {"excitation.velocity": 5.0}),
    ("vdp-mu1-v0.3", {}),
    # Van der Pol settling on its stationary peak at small eps, where the law gives values
    ("vdp-mu3-v2.3", {"perturbation.eps": 0.025, "excitation.velocity": 0.9, "output.contacts": [16, 300]}),
    ("vdp-mu3-v2.3", {"perturbation.eps": 0.0125, "excitation.velocity": 0.9, "output.contacts": [16, 300]}),
    ("vdp-mu3-v2.3", {"perturbation.params.mu": 5.0, "perturbation.eps": 0.025, "excitation.velocity": 0.9,
                      "output.contacts": [16, 300]}),
    ("fig6-eps0.1", {"perturbation.R": "-u^2", "perturbation.eps": 0.05}),  # where the former estimate understated
    ("fig6-eps0.1", {"perturbation.R": "-u^3", "perturbation.eps": 0.1}),  # cubic foundation
    ("fig8-eps0.1", {"chain.exponent": 3.0, "perturbation.R": "-(u + v)", "perturbation.eps": 0.05}),  # n = 3
    ("fig8-eps0.1", {"chain.exponent": 3.0, "perturbation.R": "-(u + v)", "perturbation.eps": 0.1}),
    ("fig8-eps0.1", {"chain.exponent": 2.0, "perturbation.R": "-(u^3 + v)", "perturbation.eps": 0.05}),  # n = 2
    ("fig8-eps0.1", {"perturbation.R": "v - u^2*v", "perturbation.eps": 0.05}),  # gain and loss
    ("fig6-eps0.1", {"perturbation.R": "-k*u", "perturbation.eps": 0.01, "perturbation.params.k": "1 + (i - 16)/50"}),
    # run only after the estimate was built (benchmarks/bench_dressed_accuracy.py: LATER, LAST)
    ("fig8-eps0.1", {"chain.exponent": 3.0, "perturbation.R": "-(u^3 + v)", "perturbation.eps": 0.03}),
    ("fig8-eps0.1", {"chain.exponent": 2.5, "perturbation.R": "-(u + v)", "perturbation.eps": 0.03}),
    ("fig8-eps0.1", {"chain.exponent": 1.8, "perturbation.eps": 0.05}),
    ("fig8-eps0.1", {"perturbation.R": "-(0.5*u^2 + v)", "perturbation.eps": 0.04}),
    ("vdp-mu3-v2.3", {"perturbation.params.mu": 4.0, "perturbation.eps": 0.03, "excitation.velocity": 1.2,
                      "output.contacts": [16, 250]}),
    ("fig6-eps0.1", {"perturbation.R": "-k*u^3", "perturbation.eps": 0.05, "perturbation.params.k": "1 + (i - 16)/80"}),
]


@pytest.mark.slow
@pytest.mark.parametrize("name, overrides", ACCURACY_SCENES)
def test_dressed_law_is_within_its_printed_accuracy_or_says_why_not(name, overrides):
    """Every value the law gives on the DNS's live range is within its own estimated error of the DNS peak (and so
    within 5 % of it); every contact without a value is explained in one line; the run's text prints the
    estimate."""
    import pulsemap
    from pulsemap.solvers.models.dressed import ACCURACY

    result = pulsemap.run(pulsemap.scene(name, **overrides), methods=["dns", "dressed-law"])
    res = result.to_dict()
    info = res["dressed-law"]
    law = res["peaks"]["dressed-law"] or [None] * len(res["contacts"])
    accuracy = info.get("accuracy") or [None] * len(res["contacts"])
    live = res["errors"]["dressed-law"]["live_range"] or [math.inf, -math.inf]
    given = 0
    for c, dns, q, a in zip(res["contacts"], res["peaks"]["dns"], law, accuracy):
        if q is None:
            continue
        assert a is not None and 0 <= a <= ACCURACY
        if dns is not None and live[0] <= c <= live[1]:
            given += 1
            assert abs(q / dns - 1) <= a, f"contact {c}: {abs(q / dns - 1):.4g} above its estimate {a:.4g}"
    why = info.get("refused") or info["message"]
    if given < len(res["contacts"]):
        assert why and "\n" not in why
    if given:
        assert info["note"].startswith("estimated accuracy +-")
        assert info["note"] in str(result)
