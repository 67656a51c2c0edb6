"""``pulsemap derive --model energy`` for an R that is not a polynomial: the energy law with its rate
tabulated by quadrature over the wave, the model ``run --methods energy-law`` evaluates."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
import sympy
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


@pytest.mark.parametrize("R, params, pole", [("u*exp(1/(u-1))", [], 1.0), ("-mu*v/(u-0.5)", ["--param", "mu=1"], 0.5)])
def test_path_through_a_pole_is_refused_at_the_amplitude_where_it_meets_it(capsys, R, params, pole):
    """As run refuses it: exit 2, one line naming the pole's term and the amplitude A at which the bead's
    path u = A X(tau) first reaches u = pole, i.e. A X(L) = pole with X(L) = sum_k S(L - k) (the final shift)."""
    from pulsemap.symbolic.profile import exact_profile

    assert main(["derive", R, *params, "--model", "energy"]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1
    match = re.search(r"infinite where the wave of amplitude A = ([0-9.e+-]+) \(peak", captured.err)
    assert match and f"its term 1/(u - {sympy.nsimplify(pole)})" in captured.err, captured.err
    prof = exact_profile(1.5)
    L = int(np.ceil(prof.tail)) + 1
    shift = sum(float(prof.S(np.array([L - k]))[0]) for k in range(2 * L + 1))
    assert float(match.group(1)) * shift == pytest.approx(pole, rel=1e-4)


def test_rates_the_quadrature_does_not_resolve_are_not_numbers(capsys):
    """A Lorentzian of width 1e-3 in u: where the path crosses it the 24-node rate is wrong; those rows are
    refused (null, 'not resolved'), and every rate still given agrees with 8 times the nodes."""
    from pulsemap.solvers.models.codeload import force_module
    from pulsemap.solvers.models.energy_quadrature import NODES, RATE_TOLERANCE, bead_force, wave_table, work

    args = ["-mu*v/(k+(u-0.5)^2)", "--param", "mu=1", "--param", "k=1e-6"]
    doc = _derive_json(capsys, *args)
    rows = doc["law"]["table"]
    assert any(not r["resolved"] for r in rows) and any(r["resolved"] for r in rows)
    module = force_module("-mu*v/(k+(u-0.5)^2)", ("k", "mu"))
    force = bead_force(module, 0.1, lambda bead: tuple({"mu": 1.0, "k": 1e-6}[p] for p in module.PARAMS))
    fine = wave_table(1.5, 8 * NODES)
    worst_refused = 0.0
    for row in rows:
        exact = work(lambda x, v: force(x, v, 1.0), row["A"], fine) / fine.E1
        if row["resolved"]:
            assert row["rate_dB_di"] == pytest.approx(exact, rel=10 * RATE_TOLERANCE, abs=1e-300)
        else:
            assert row["rate_dB_di"] is None and row["dlnA_di"] is None
            worst_refused = max(worst_refused, row["error"] / abs(exact))
    assert worst_refused > 1e-3  # what is refused was really wrong
    assert main(["derive", *args, "--model", "energy"]) == 0
    out = capsys.readouterr().out
    assert "not resolved" in out and "nan" not in out.lower()
