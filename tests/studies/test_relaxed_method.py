"""Method 'relaxed' in run_scene: peaks next to the DNS, live-range errors, refusals reported."""

from __future__ import annotations

import pytest

from conftest import scene_toml, write_scene
from pulsemap.solvers.data.scene import load_scene
from pulsemap.solvers.studies.errors import live_contacts, model_error
from pulsemap.solvers.studies.run import run_scene


def test_relaxed_runs_beside_the_dns_with_live_range_errors(tmp_path):
    scene = load_scene(str(write_scene(tmp_path, scene_toml("damped", eps=0.1, contacts=(16, 40),
                                                            methods=("dns", "relaxed")))))
    res = run_scene(scene)
    assert res["relaxed"]["status"] in ("ok", "died") and res["relaxed"]["segment_runs"] > 0
    err = res["errors"]["relaxed"]
    assert err["live_range"][0] == 16 and err["missing"] == 0
    assert err["rms_pct"] < 2  # the damped pulse: the relaxed map within 2 % of the DNS


def test_site_dependent_r_it_cannot_take_is_refused_not_raised(tmp_path):
    text = scene_toml("graded", beads=60, eps=0.1, contacts=(16, 30), methods=("relaxed",))
    text = text.replace('R = "-mu*v"', 'R = "-(mu*v + k*u)"').replace(
        "mu = 1.0", "mu = {uniform = [0, 1], seed = 4}\nk = {uniform = [0, 1], seed = 3}")
    assert "seed = 3" in text
    res = run_scene(load_scene(str(write_scene(tmp_path, text))))
    assert "refused" in res["relaxed"] and res["peaks"]["relaxed"] is None


def test_live_range_ends_at_two_percent_of_the_seed():
    contacts = list(range(15, 22))
    dns = [1.0, 0.5, 0.1, 0.03, 0.021, 0.019, None]
    assert live_contacts(contacts, dns, 15, 1.0) == [16, 17, 18, 19]
    err = model_error(contacts, dns, [None, 0.5, 0.1, 0.03, None, 0.0, None], 15, 1.0)
    assert err["live_range"] == [16, 19] and err["compared"] == 3 and err["missing"] == 1
    assert err["rms_pct"] == pytest.approx(50.0) and err["max_pct"] == 100.0  # 19 has no value: 100 %
    err = model_error(contacts, dns, [None, 0.55, 0.1, 0.03, 0.021, None, None], 15, 1.0)
    assert err["missing"] == 0 and err["rms_pct"] == pytest.approx(100 * (0.1 ** 2 / 4) ** 0.5)
    assert model_error(contacts, dns, dns, 15, None)["rms_pct"] is None  # no seed: no live range


@pytest.mark.parametrize("eps, mu", [pytest.param(0.05, "1.0", marks=pytest.mark.slow), (0.02, "1.5"),
                                     (0.02, '"0.5 + 0.05*(i - 16)"'),
                                     pytest.param(0.02, "{uniform = [0.5, 1.5], seed = 7}", marks=pytest.mark.slow)],
                         ids=["mu=1", "mu=1.5", "graded", "random"])
def test_coulomb_friction_within_5_percent_of_the_dns(tmp_path, eps, mu):
    """-mu*sign(v), uniform or site-dependent: the pulse dies at a finite contact and relaxed follows it
    (segment runs on the compiled engine, Rodas4 through the ramp; the live range of `pulsemap run`)."""
    text = scene_toml("coulomb", beads=80, eps=eps, contacts=(16, 70), methods=("dns", "relaxed"))
    text = text.replace('R = "-mu*v"', 'R = "-mu*sign(v)"').replace("mu = 1.0", f"mu = {mu}")
    res = run_scene(load_scene(str(write_scene(tmp_path, text))))
    assert res["relaxed"]["status"] in ("ok", "died") and res["relaxed"]["segment_runs"] > 0
    err = res["errors"]["relaxed"]
    assert err["live_range"][0] == 16 and err["compared"] >= 10 and err["missing"] == 0
    assert err["rms_pct"] < 5


def test_a_pulse_that_dies_within_the_onset_has_values_until_it_dies(tmp_path):
    """Coulomb friction with eps mu = 0.15: the pulse dies four contacts in, inside the onset table; relaxed
    gives each of them (the runs entering there reach them) and says the pulse dies within the onset."""
    text = scene_toml("coulomb", beads=60, eps=0.05, contacts=(16, 40), methods=("dns", "relaxed"))
    text = text.replace('R = "-mu*v"', 'R = "-mu*sign(v)"').replace("mu = 1.0", "mu = 3.0")
    res = run_scene(load_scene(str(write_scene(tmp_path, text))))
    err = res["errors"]["relaxed"]
    assert err["live_range"][0] == 16 and 3 <= err["compared"] < 5 and err["missing"] == 0  # dies in the onset
    assert err["max_pct"] < 1
    assert res["relaxed"]["status"] == "died" and "within the onset" in res["relaxed"]["message"]


def test_a_table_row_skips_the_stated_accuracy_and_keeps_the_same_errors(tmp_path, monkeypatch):
    """The leave-one-run-out accuracy costs seconds of spline fits from an empty cache and no table column
    uses it: a row does not compute it; a run reports it, and the peaks and errors are the same either way."""
    from pulsemap.solvers.models import relaxed
    from pulsemap.solvers.studies.table import Column, scene_row

    scene = load_scene(str(write_scene(tmp_path, scene_toml("damped", eps=0.1, contacts=(16, 40),
                                                            methods=("dns", "relaxed")))))
    with_accuracy = run_scene(scene)
    assert with_accuracy["relaxed"]["bulk_accuracy_log_ratio"] > 0
    calls = []
    real = relaxed.RelaxedModel.accuracy
    monkeypatch.setattr(relaxed.RelaxedModel, "accuracy", lambda self: calls.append(1) or real(self))
    without = run_scene(scene, stated_accuracy=False)
    assert "bulk_accuracy_log_ratio" not in without["relaxed"] and not calls
    assert without["peaks"]["relaxed"] == with_accuracy["peaks"]["relaxed"]
    assert without["errors"]["relaxed"] == with_accuracy["errors"]["relaxed"]
    row = scene_row("damped", columns=(Column("relaxed", "exact"),), scene=scene)
    assert not calls and row["errors"]["relaxed/exact"]["rms_pct"] == with_accuracy["errors"]["relaxed"]["rms_pct"]


def test_stated_accuracy_counts_in_the_build_time(tmp_path, monkeypatch):
    """timings_s.relaxed holds the stated accuracy's leave-one-run-out fits: they are part of the wait."""
    import time

    from pulsemap.solvers.models.relaxed import RelaxedModel

    accuracy = RelaxedModel.accuracy

    def slow_accuracy(self):
        time.sleep(0.5)
        return accuracy(self)

    scene = load_scene(str(write_scene(tmp_path, scene_toml("damped", eps=0.1, contacts=(16, 30),
                                                            methods=("relaxed",)))))
    run_scene(scene)  # cold: the segment runs and the accuracy cached
    monkeypatch.setattr(RelaxedModel, "accuracy", slow_accuracy)
    res = run_scene(scene)
    assert res["timings_s"]["relaxed"] >= 0.5
    assert 0.0 < res["relaxed"]["bulk_accuracy_log_ratio"] < 0.1
