"""The model table (studies/run/models.py RUNNERS): every model the scene schema accepts has a runner and
a title, a new model is one row, and every model is computed and reported on its own: one that fails
says why in its own entry while the others are written, and the run exits 0."""

from __future__ import annotations

import json
import math

import pytest

from conftest import write_scene
from pulsemap.solvers.cli.main import main
from pulsemap.solvers.data.scene import METHODS, load_scene
from pulsemap.solvers.studies.methods import MODELS
from pulsemap.solvers.studies.run import start_run
from pulsemap.solvers.studies.run.models import RUNNERS, Runner, run_models

# R = k_i (u^2 - v), eps 0.1: the chain blows up behind the front (t ~ 30) and the energy map grows past
# float64 (its W(A) has A^(17/4)); the momentum balance is undefined for it (a term without v).
BLOWS_UP = """name = "blows-up"
[chain]
beads = 140
exponent = 1.5
first_perturbed = 16
[excitation]
velocity = 1.0
[perturbation]
R = "k*(u^2 - v)"
eps = 0.1
[perturbation.params]
k = {uniform = [0.5, 1.5], seed = 1}
[output]
contacts = [16, 120]
methods = ["dns", "map", "energy-map", "energy-law", "momentum-map"]
"""


def test_every_model_the_schema_accepts_has_a_runner_and_a_title():
    assert set(RUNNERS) == set(MODELS) == set(METHODS) - {"dns"}
    for name, runner in RUNNERS.items():
        assert callable(runner.run) and isinstance(runner.title, str) and len(runner.title) > 10, name
    assert len({r.title for r in RUNNERS.values()}) == len(RUNNERS)  # each names its own model


def _state(methods):
    state = start_run(load_scene("fig8-eps0.3"), ["map"], None, None, None)
    state.methods = tuple(methods)  # a registered toy model is no scene method: past the schema's check
    return state


def test_a_registered_toy_model_runs_and_is_reported(monkeypatch):
    def toy(state, name, inputs):
        """P_i = seed peak * 0.99^(i - seed): a pulse that loses 1 % per contact."""
        seed = state.out["seed"]
        state.out["peaks"][name] = [seed["peak"] * 0.99 ** (c - seed["contact"]) for c in state.contacts]
        return {"status": "ok", "seed_A": inputs.seed_A}

    monkeypatch.setitem(RUNNERS, "toy", Runner("toy model: one percent per contact", toy))
    state = _state(["toy", "map"])
    run_models(state)
    out = state.out
    assert out["toy"] == {"model": "toy model: one percent per contact", "status": "ok", "seed_A": out["seed"]["A"]}
    assert out["peaks"]["toy"][0] == pytest.approx(0.99 * out["seed"]["peak"], rel=1e-15)
    assert out["map"]["model"] == RUNNERS["map"].title and any(p is not None for p in out["peaks"]["map"])


def test_a_toy_models_preparation_reaches_its_runner_or_refuses_it(monkeypatch):
    """Runner.prepare runs before the models: what it forms is the runner's ``inputs.prepared[name]``; a
    preparation that says why not refuses the model in its own entry, and the others still run."""
    def toy(state, name, inputs):
        state.out["peaks"][name] = [inputs.prepared[name]] * len(state.contacts)
        return {"status": "ok"}

    monkeypatch.setitem(RUNNERS, "toy", Runner("toy model: a prepared constant", toy, lambda state: (0.5, None)))
    monkeypatch.setitem(RUNNERS, "nope", Runner("toy model: refused while preparing", toy,
                                                lambda state: (None, "no constant for this scene")))
    state = _state(["toy", "nope", "map"])
    run_models(state)
    assert state.out["peaks"]["toy"] == [0.5] * len(state.contacts)
    assert state.out["nope"] == {"model": "toy model: refused while preparing", "refused": "no constant for this scene"}
    assert any(p is not None for p in state.out["peaks"]["map"])


@pytest.mark.parametrize("error, said", [(OverflowError("math range error"), "OverflowError (math range error)"),
                                         (ZeroDivisionError("float division by zero"), "ZeroDivisionError")])
def test_a_model_that_fails_is_reported_in_its_own_entry_and_the_others_run(monkeypatch, error, said):
    def broken(state, name, inputs):
        state.out["peaks"][name] = [1.0] * len(state.contacts)  # written before it fails: taken back
        raise error

    monkeypatch.setitem(RUNNERS, "broken", Runner("a model whose numbers leave float64", broken))
    state = _state(["broken", "map"])
    run_models(state)
    entry = state.out["broken"]
    assert set(entry) == {"model", "failed"} and entry["failed"].startswith(said)
    assert "\n" not in entry["failed"] and "seeded with peak" in entry["failed"]
    assert state.out["peaks"]["broken"] is None
    assert f"broken failed: {entry['failed']}" in state.warnings
    assert "failed" not in state.out["map"] and any(p is not None for p in state.out["peaks"]["map"])


def test_a_bug_in_a_model_is_not_taken_for_its_failure(monkeypatch):
    def buggy(state, name, inputs):
        return {}["no such key"]

    monkeypatch.setitem(RUNNERS, "buggy", Runner("a model with a bug", buggy))
    with pytest.raises(KeyError):
        run_models(_state(["buggy"]))


def test_an_overflowing_energy_map_takes_nothing_else_down(tmp_path, capsys):
    scene = write_scene(tmp_path, BLOWS_UP)
    assert main(["run", str(scene), "--quiet", "--json", str(tmp_path / "out.json")]) == 0
    capsys.readouterr()
    res = json.loads((tmp_path / "out.json").read_text())
    contacts = res["contacts"]
    assert res["dns"]["stop_reason"].startswith("blow-up")
    for name in ("dns", "map", "energy-law"):
        assert any(p is not None for p in res["peaks"][name]), name
    assert "refused" in res["momentum-map"] and res["peaks"]["momentum-map"] is None
    # the energy map blows up: its amplitude grows every contact up to the one it cannot reach
    energy = res["energy-map"]
    end = energy["ended_at"]
    assert energy["status"] == "blow-up" and f"blows up at contact {end}" in energy["message"]
    assert "die" not in energy["message"] and "float64" in energy["message"]
    values = [p for c, p in zip(contacts, res["peaks"]["energy-map"]) if c < end]
    assert len(values) == end - contacts[0] and all(b > a for a, b in zip(values, values[1:]))
    assert all(p is None for c, p in zip(contacts, res["peaks"]["energy-map"]) if c >= end)
    assert math.log10(values[-1]) > 100  # it went all the way to float64's end, not stopped early
    assert any(w.startswith(f"energy-map: the energy map blows up at contact {end}") for w in res["warnings"])


def test_relaxed_tells_segment_runs_that_blow_up_from_runs_that_die(tmp_path):
    from pulsemap.solvers.studies.run import run_scene

    res = run_scene(load_scene(str(write_scene(tmp_path, BLOWS_UP))), methods=["dns", "relaxed"])
    relaxed = res["relaxed"]
    assert relaxed["status"] == "blow-up", relaxed
    assert "segment runs there blow up" in relaxed["message"] and "die" not in relaxed["message"]
    damped = run_scene(load_scene("fig8-eps1"), methods=["relaxed"])["relaxed"]
    assert damped["status"] in ("ok", "died") and "blow" not in damped["message"]


def test_a_model_whose_derivation_fails_is_reported_and_the_others_run(monkeypatch):
    from pulsemap.solvers.studies.run import models
    from pulsemap.symbolic.budget import DeriveTimeout

    def too_slow(*args, **kwargs):
        raise DeriveTimeout("the map's derivation did not finish within --max-seconds 1: give more time")

    monkeypatch.setattr(models, "map_module", too_slow)
    state = _state(["map", "longwave", "energy-law"])
    run_models(state)
    for name in ("map", "longwave"):
        assert state.out[name] == {"model": RUNNERS[name].title, "failed": "the map's derivation did not finish "
                                   "within --max-seconds 1: give more time"}
        assert state.out["peaks"][name] is None
    assert "failed" not in state.out["energy-law"] and any(p is not None for p in state.out["peaks"]["energy-law"])


def test_the_energy_map_by_quadrature_blows_up_where_the_generated_one_does(tmp_path):
    """R times exp(1e-3 sin u) is no polynomial: its energy map is evaluated by quadrature of R over the wave,
    independently of the generated module, and blows up within a contact of the polynomial R's."""
    from pulsemap.solvers.studies.run import run_scene

    runs = {}
    for label, text in (("generated", BLOWS_UP), ("quadrature", BLOWS_UP.replace('"k*(u^2 - v)"',
                                                                                   '"k*(u^2 - v)*exp(1e-3*sin(u))"'))):
        res = run_scene(load_scene(str(write_scene(tmp_path, text, f"{label}.toml"))), methods=["energy-map"])
        runs[label] = res["energy-map"]
    assert runs["quadrature"]["generated"] is None and runs["generated"]["generated"] is not None
    for entry in runs.values():
        assert entry["status"] == "blow-up" and "blows up at contact" in entry["message"], entry
    assert abs(runs["quadrature"]["ended_at"] - runs["generated"]["ended_at"]) <= 1
