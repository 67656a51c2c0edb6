"""The kinds of perturbation are one table (solvers/studies/run/kinds.py): the models a scene runs and the
studies that take it follow the rows of the kinds it states, and a new kind is one row."""

from __future__ import annotations

from dataclasses import replace

import pytest

import pulsemap
from pulsemap.solvers.data.scene import METHODS
from pulsemap.solvers.studies.methods import MODELS, RunError
from pulsemap.solvers.studies.run import kinds


def _scene(**tables):
    data = {"name": "kinds-test", "excitation": {"velocity": 1.0}, "output": {"contacts": [16, 40]}}
    data.update(tables)
    return pulsemap.scene(data)


def test_every_model_the_schema_takes_is_derived_for_an_onsite_r():
    onsite = next(k for k in kinds.KINDS if k.table == "perturbation")
    assert set(MODELS) <= set(METHODS) and onsite.models == frozenset(MODELS)
    assert all(k.models <= onsite.models for k in kinds.KINDS)  # every model a kind has is a model of the table


@pytest.mark.parametrize("tables, stated", [
    ({"perturbation": {"R": "-v", "eps": 0.01}}, ["perturbation"]),
    ({"contact": {"P": "w", "eps": 0.01}}, ["contact"]),
    ({"masses": {"m": 1.2}, "perturbation": {"R": "-u", "eps": 0.01}}, ["perturbation", "masses"]),
    ({"perturbation": {"R": "0", "eps": 0.0}}, []),
])
def test_a_scene_states_the_kinds_of_its_tables(tables, stated):
    assert [k.table for k in kinds.given(_scene(**tables))] == stated


def test_a_model_runs_only_where_every_stated_kind_has_it():
    both = _scene(perturbation={"R": "-v", "eps": 0.01}, contact={"P": "w", "eps": 0.01})
    refused = kinds.refusals(both, ["map", "energy-law", "relaxed", "longwave"])
    assert set(refused) == {"map", "longwave"}
    assert "a contact-law term P" in refused["map"] and "energy-law" in refused["map"]
    assert kinds.refusals(_scene(perturbation={"R": "-v", "eps": 0.01}), list(MODELS)) == {}


def test_a_study_refuses_a_kind_it_does_not_take_and_takes_one_it_does():
    masses = _scene(masses={"m": 1.2})
    with pytest.raises(RunError, match="bead masses: bifurcation builds its chains without it"):
        kinds.require(masses, "bifurcation")
    kinds.require(masses, "bench")
    kinds.require(_scene(perturbation={"R": "-v", "eps": 0.01}), "bifurcation")


def test_a_new_kind_is_one_row(monkeypatch):
    """A toy kind (stated by every scene, with one model and one study) changes refusals and studies alone."""
    toy = kinds.PerturbationKind("a toy term", "toy", lambda s: True, frozenset({"energy-law"}), frozenset({"bench"}))
    monkeypatch.setattr(kinds, "KINDS", kinds.KINDS + (toy,))
    sc = _scene(perturbation={"R": "-v", "eps": 0.01})
    assert set(kinds.refusals(sc, ["map", "energy-law"])) == {"map"}
    kinds.require(sc, "bench")
    with pytest.raises(RunError, match="a toy term"):
        kinds.require(sc, "ensemble")
    monkeypatch.setattr(kinds, "KINDS", kinds.KINDS[:-1] + (replace(toy, studies=frozenset()),))
    with pytest.raises(RunError, match="a toy term"):
        kinds.require(sc, "bench")


def test_the_plain_sweep_chains_refuse_masses_the_ensemble_takes(tmp_path):
    """An ensemble of random masses runs each realisation as `pulsemap run` does; the plain sweep chains
    (ensemble_points, bifurcation) would drop the masses, so they refuse the scene instead of running another chain."""
    from pulsemap.solvers.studies.ensemble import ensemble_points

    masses = _scene(masses={"m": 1.1}, chain={"beads": 60},
                    perturbation={"R": "-k*u", "eps": 0.01, "params": {"k": {"uniform": [0.5, 1.5], "seed": 1}}})
    kinds.require(masses, "ensemble")
    with pytest.raises(RunError, match="sweep tasks builds its chains without it"):
        ensemble_points(masses, 2, 0)


def test_an_ensemble_of_masses_refuses_a_map_variant_it_would_not_use():
    from pulsemap.solvers.studies.ensemble import EnsembleError, ensemble

    masses = _scene(masses={"m": {"uniform": [0.9, 1.1], "seed": 1}}, chain={"beads": 60},
                    perturbation={"R": "0", "eps": 0.0})
    with pytest.raises(EnsembleError, match="variant '1d' is the map's"):
        ensemble(masses, 2, 0, variant="1d")
