"""Runtime guards: the map says at which contact it cannot go on, and results outside
the map's assumptions carry warnings in the output of ``pulsemap run``.

(The DNS blow-up guard is tested with the DNS.)
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from pulsemap.solvers.cli.main import main
from pulsemap.solvers.models.codeload import map_module
from pulsemap.solvers.models.map_iteration import iterate_map
from pulsemap.solvers.data.scene import with_overrides

SOFTENING = """\
name = "softening"
[chain]
first_perturbed = 16
[excitation]
velocity = 1.0
[perturbation]
R = "beta*u^3"        # beta > 0: a softening foundation that pumps the pulse up
eps = 0.1
[perturbation.params]
beta = 0.2
[output]
contacts = [16, 120]
methods = ["map"]
"""


@pytest.fixture(scope="module")
def softening_run():
    mod = map_module("beta*u^3", ("beta",), 1.5, "exact", "1d")
    return mod, iterate_map(mod, 1.0 / mod.S0, 15, 120, 0.1, {"beta": 0.2})


def test_map_without_positive_root_names_the_contact(softening_run):
    mod, run = softening_run
    assert run.status == "no root"
    stop = int(run.contacts[-1]) + 1
    assert 20 < stop < 120  # it got some way: the root disappears along the chain, not at once
    assert f"no positive root of the map at contact {stop}" in run.message
    assert f"the map stops at contact {stop - 1}" in run.message
    assert np.all(np.diff(run.A) > 0)  # the foundation pumped the amplitude up on the way
    # independent check: F1(A_{stop-1}, A) of the 1d map keeps one sign over twelve decades of A ...
    a_prev = float(run.A[-1])
    grid = np.geomspace(a_prev * 1e-6, a_prev * 1e6, 20001)
    F1 = np.asarray(mod.map_residual(a_prev, grid, 0.1, 0.2)[0])
    assert np.all(np.isfinite(F1)) and (np.all(F1 > 0) or np.all(F1 < 0))
    # ... while the value the map kept at the contact before is a root
    a_before = float(run.A[-2])
    assert abs(mod.map_residual(a_before, a_prev, 0.1, 0.2)[0]) < 1e-10 * mod.f1 * a_prev**mod.P


def test_run_json_says_where_the_map_stopped(softening_run, tmp_path, capsys):
    _, run = softening_run
    stop = int(run.contacts[-1]) + 1
    scene, out = tmp_path / "softening.toml", tmp_path / "out.json"
    scene.write_text(SOFTENING, encoding="utf-8")
    assert main(["run", str(scene), "--variant", "1d", "--seed-peak", "1.0", "--quiet", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["map"]["status"] == "no root"
    assert any(w.startswith(f"map: no positive root of the map at contact {stop}") for w in data["warnings"])
    peaks = dict(zip(data["contacts"], data["peaks"]["map"]))
    assert all(peaks[c] is not None for c in range(16, stop)) and all(peaks[c] is None for c in range(stop, 121))
    assert f"warning: map: no positive root of the map at contact {stop}" in capsys.readouterr().out


def test_forcing_ratio_of_damping_is_the_closed_form():
    """R = -mu v: the eps term of Eq. 23 is -eps mu g1_0010 A with g1_0010 = int S' = S(0), so the
    ratio to the contact term f1 A^P is eps mu S(0) A^(1-P) / f1 (constants from derive, not
    from the generated module)."""
    from pulsemap.symbolic.integrals import constants
    from pulsemap.symbolic.profile import get_profile

    S0 = get_profile("exact", 1.5).S0
    f1 = constants(["f1"], n=1.5, profile="exact")["f1"].value
    mod = map_module("-mu*v", ("mu",), 1.5, "exact", "paper")
    run = iterate_map(mod, 0.5, 15, 40, 0.3, {"mu": 1.0})
    assert run.forcing_ratio.shape == run.A.shape and run.A.size > 5
    expected = 0.3 * S0 * run.A ** (1 - 1.25) / f1
    np.testing.assert_allclose(run.forcing_ratio, expected, rtol=1e-9)
    assert run.max_forcing_ratio == pytest.approx(expected.max(), rel=1e-9)


def test_run_warnings_outside_the_assumptions(tmp_path):
    """eps not small, the DNS pulse died, the map died, the eps term not small, the law ended."""
    scene, out = tmp_path / "strong.toml", tmp_path / "out.json"
    scene.write_text(SOFTENING.replace('R = "beta*u^3"', 'R = "-mu*v"').replace("beta = 0.2", "mu = 1.0")
                     .replace("eps = 0.1", "eps = 0.5").replace("[16, 120]", "[16, 60]")
                     .replace('["map"]', '["map", "longwave", "dns"]'), encoding="utf-8")
    assert main(["run", str(scene), "--quiet", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    warnings = data["warnings"]
    for start in ("eps = 0.5 is not small", "DNS: no live primary pulse at contacts", "map: pulse died at contact",
                  "map: at contact 16 the eps term of Eq. 23 exceeds 0.3", "long-wave law: extinction"):
        assert sum(w.startswith(start) for w in warnings) == 1, (start, warnings)
    assert data["map"]["max_forcing_ratio"] > 0.3


def test_no_warning_inside_the_assumptions(tmp_path):
    """The control: a weak cubic foundation over a few contacts warns about nothing."""
    scene, out = tmp_path / "weak.toml", tmp_path / "out.json"
    scene.write_text(SOFTENING.replace("beta = 0.2", "beta = -1.0").replace("[16, 120]", "[16, 30]")
                     .replace('["map"]', '["map", "longwave"]'), encoding="utf-8")
    assert main(["run", str(scene), "--seed-peak", "1.0", "--quiet", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["warnings"] == []
    assert data["map"]["status"] == "ok" and 0 < data["map"]["max_forcing_ratio"] < 0.3


def _map_run(n: float, variant: str, last: int = 60) -> dict:
    from pulsemap.solvers.studies.run import run_scene
    from pulsemap.solvers.data.scene import load_scene

    scene = with_overrides(load_scene("fig8-eps0.1"), exponent=n, contacts=(16, last), methods=("map",))
    return run_scene(scene, variant=variant, seed_peak=0.5)


def test_paper_drift_warning_matches_the_closed_form():
    """At n = 1.1 the literal map shrinks A by (1 + f7/(2 f1))^(-1/P) per contact at eps = 0."""
    res = _map_run(1.1, "paper")
    mod = map_module("-mu*v", ("mu",), 1.1, "exact", "paper")
    per_contact = (1 + mod.f7 / (2 * mod.f1)) ** (-1 / mod.P)
    expected = per_contact ** (60 - 15) - 1
    assert res["map"]["eps0_drift"] == pytest.approx(expected, rel=1e-6)
    assert any("drifts by" in w and "erratum 5" in w and "docs/errata.rst" in w for w in res["warnings"])
    assert any("spans more than two contacts" in w for w in res["warnings"])


def test_drift_free_variants_and_narrow_pulse_do_not_warn():
    corrected = _map_run(1.1, "corrected")
    assert "eps0_drift" not in corrected["map"]
    assert not any("drifts by" in w for w in corrected["warnings"])
    narrow = _map_run(1.5, "paper")
    assert abs(narrow["map"]["eps0_drift"]) < 0.01  # 1.2 % per 100 contacts at n = 3/2
    assert not any("spans more than two contacts" in w or "drifts by" in w for w in narrow["warnings"])
