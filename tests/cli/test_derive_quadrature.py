"""``pulsemap derive --model energy`` for an R that is not a polynomial: the energy law with its rate
tabulated by quadrature over the wave, the model ``run --methods energy-law`` evaluates."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline

import pulsemap
from pulsemap.solvers.api.derivation import quadrature_energy_law
from pulsemap.solvers.cli.main import main
from pulsemap.symbolic.balance import derive_balance
from pulsemap.symbolic.perturbation import make_perturbation


def _derive_json(capsys, *args) -> dict:
    assert main(["derive", *args, "--model", "energy", "--quiet", "--json", "-"]) == 0
    return json.loads(capsys.readouterr().out)


@pytest.mark.parametrize("R, mu", [("-mu*sin(u)", 0.05), ("-mu*v*abs(v)", 1.0)])
def test_tabulated_law_integrates_to_run_energy_law(capsys, R, mu):
    """The derived table, interpolated and integrated from run's seed, gives run's energy-law peaks."""
    doc = _derive_json(capsys, R, "--param", f"mu={mu}", "--eps", "0.1")
    law = doc["law"]
    assert law["kind"] == "quadrature (tabulated)" and law["max_rel_error"] < 1e-8
    A = np.array([row["A"] for row in law["table"]])
    g = np.array([row["dlnA_di"] for row in law["table"]])
    sc = pulsemap.scene("default", **{"perturbation.R": R, "perturbation.params": {"mu": mu},
                                      "perturbation.eps": 0.1, "output.contacts": (16, 60)})
    result = pulsemap.run(sc, methods=["energy-law"])
    peaks = np.array(result.peaks["energy-law"], dtype=float)
    seed = result.to_dict()["seed"]

    def integrate(scale: float) -> np.ndarray:
        spline = CubicSpline(np.log(A), scale * g)
        sol = solve_ivp(lambda i, y: [spline(y[0])], (seed["contact"], result.contacts[-1]), [np.log(seed["A"])],
                        t_eval=np.array(result.contacts, dtype=float), rtol=1e-10, atol=1e-12)
        return np.exp(sol.y[0]) * doc["S0"]

    assert np.max(np.abs(integrate(1.0) / peaks - 1)) < 1e-3
    assert np.max(np.abs(integrate(1.1) / peaks - 1)) > 3e-3  # a 10 % wrong rate is seen


def test_quadrature_rate_equals_the_monomial_law_for_a_polynomial_R():
    """For a polynomial R the quadrature table and the law from the monomial integrals (mpmath) agree."""
    pert = make_perturbation("-mu*v - k*u^3", 0.1, {"mu": 0.7, "k": 0.3})
    law = derive_balance(pert, "energy").law
    for row in quadrature_energy_law(pert)["law"]["table"]:
        B = row["A"] ** 2.5
        exact = law.eps * sum(c * B ** float(p) for c, p in zip(law.coefficients, law.powers)) / law.K
        assert row["rate_dB_di"] == pytest.approx(exact, rel=1e-9, abs=1e-300)


def test_text_report_and_refused_options(capsys):
    assert main(["derive", "-mu*sin(u)", "--param", "mu=1", "--model", "energy", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "Amplitude law: by quadrature, rate tabulated" in out and "d ln A/di" in out
    for extra in (["--A0", "1"], ["--profile", "pade"], ["--latex"], ["--dps", "30"]):
        assert main(["derive", "-mu*sin(u)", "--param", "mu=1", "--model", "energy", *extra]) == 2
        assert "pulsemap: error:" in capsys.readouterr().err
    assert main(["derive", "-k*sin(u)", "--param", "k=1,2,3", "--model", "energy"]) == 2
    assert "uniform R" in capsys.readouterr().err
