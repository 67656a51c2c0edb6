"""pulsemap.derive_contact and `pulsemap derive P --model contact`: the contact energy law as a user gets it."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
import sympy

import pulsemap


@pytest.mark.parametrize("P, params", [("gamma*w", {"gamma": 1.0}), ("gamma*d^(1/2)*w", {"gamma": 2.0})])
def test_the_closed_form_law_solves_its_ode(P, params):
    """A(i) substituted into K dB/di = eps C B^p (B = A^Q) leaves no residual."""
    d = pulsemap.derive_contact(P, eps=0.02, **params)
    law = d.law
    assert law.kind == "power law" and law.law is not None
    A = law.law
    i = next(s for s in A.free_symbols if s.name == "i")
    values = {s: v for s in A.free_symbols for name, v in (("A_0", 0.6), ("i_0", 15.0), ("lambda_L", law.rate()))
              if s.name == name}
    B = A ** law.Q
    lhs = law.K * sympy.diff(B, i)
    rhs = law.eps * sum(c * B**p for c, p in zip(law.coefficients, law.powers))
    for k in (16.0, 40.0, 80.0):
        at = {**values, i: k}
        assert float((lhs - rhs).subs(at)) == pytest.approx(0.0, abs=1e-12 * abs(float(lhs.subs(at))) + 1e-15)
    assert float(A.subs({**values, i: 80.0})) < 0.6  # a dissipative contact: the amplitude falls


def test_an_elastic_correction_does_no_work_but_jumps_at_entry():
    d = pulsemap.derive_contact("c*d^(5/2)", eps=0.1)
    assert d.law.kind == "constant"
    (elastic,) = d.elastic
    assert -1.0 < elastic.jump < 0.0 < elastic.speed


def test_a_free_parameter_stays_a_symbol_and_bad_p_is_refused():
    d = pulsemap.derive_contact("gamma*w", eps=0.02)
    assert "gamma" in {s.name for s in d.law.ode().free_symbols}
    with pytest.raises(ValueError, match="belong in R"):
        pulsemap.derive_contact("v*w")
    with pytest.raises(ValueError, match="zero overlap"):
        pulsemap.derive_contact("gamma + d*w", gamma=1)


@pytest.mark.process
def test_the_command_line_derives_a_contact_law(tmp_path):
    out = tmp_path / "law.json"
    proc = subprocess.run([sys.executable, "-m", "pulsemap.solvers.cli.main", "derive", "gamma*d^(1/2)*w", "--model",
                           "contact", "--eps", "0.05", "--param", "gamma=1", "--json", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(out.read_text())
    (term,) = doc["terms"]
    assert term["q"] == "5/4" and term["integral_value"] > 0
    assert "power law" in proc.stdout
    bad = subprocess.run([sys.executable, "-m", "pulsemap.solvers.cli.main", "derive", "w^(1/2)", "--model", "contact"],
                         capture_output=True, text=True, timeout=300)
    assert bad.returncode == 2 and "powers of w" in bad.stderr
