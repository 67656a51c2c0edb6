"""Ensembles of random chains (Eq. 42, Fig. 13) through the sweep engine."""

import json

import numpy as np
import pytest

from pulsemap.solvers.studies.ensemble import EnsembleError, derived_seed, ensemble, ensemble_points, statistics
from pulsemap.solvers.studies.points import bead_params
from pulsemap.solvers.studies.points import plain_chain
from pulsemap.solvers.studies.run import run_scene
from pulsemap.solvers.data.scene import load_scene, with_overrides

FIG13 = "fig13-seed1"


def _scene(last=30):
    return with_overrides(load_scene(FIG13), contacts=(16, last))


def test_derived_seeds_are_reproducible_distinct_and_independent_of_the_ensemble_size():
    seeds = [derived_seed(7, j) for j in range(50)]
    assert len(set(seeds)) == 50
    assert seeds == [derived_seed(7, j) for j in range(50)]
    assert derived_seed(7, 0, 1) != derived_seed(7, 0, 0) and derived_seed(8, 0) != derived_seed(7, 0)
    small = ensemble_points(_scene(), 2, 7)
    large = ensemble_points(_scene(), 5, 7)
    assert large[:2] == small
    assert [p["params"]["k"]["seed"] for p in large] == seeds[:5]


def test_worker_draws_equal_the_scenes_per_bead_values():
    sc = _scene()
    values = bead_params(plain_chain(sc))
    assert np.array_equal(values["k"], sc.perturbation.bead_values("k", sc.beads))


def test_a_realisation_equals_pulsemap_run_of_that_seed(tmp_path):
    """The sympy-free worker gives exactly run_scene's DNS and map peaks for the same chain."""
    sc = _scene()
    rep = ensemble(sc, 3, seed=11, out=str(tmp_path / "e.jsonl"), max_workers=1)
    json.dumps(rep)
    recs = [json.loads(line) for line in (tmp_path / "e.jsonl").read_text().splitlines()]
    assert len(recs) == 3 and rep["failed"] == []
    j = 2
    seed = derived_seed(11, j)
    assert rep["derived_seeds"][j] == {"k": seed}
    ref = run_scene(with_overrides(sc, params={"k": {"uniform": [0, 1], "seed": seed}}),
                    methods=["dns", "map", "relaxed"])
    res = recs[j]["result"]
    k0 = res["contacts"].index(16)
    assert res["peaks"][k0:] == ref["peaks"]["dns"]
    assert res["map_peaks"][k0:] == ref["peaks"]["map"]
    assert res["seed_peak"] == ref["dns"]["seed_peak"]
    row = rep["statistics"]["realisations"][j]  # the realisation's map error is the one run reports
    assert {k: row[k] for k in ref["errors"]["map"]} == ref["errors"]["map"]
    # the relaxed model's and the map's errors per realisation are run's, over the same live range
    row = rep["relaxed"]["realisations"][j]
    for method in ("relaxed", "map"):
        assert row[method]["rms_pct"] == pytest.approx(ref["errors"][method]["rms_pct"], rel=1e-12)
    assert rep["relaxed"]["relaxed_rms_pct"]["n"] == 3


def test_statistics_per_contact_recomputed_from_the_records(tmp_path):
    sc = _scene()
    out = tmp_path / "s.jsonl"
    rep = ensemble(sc, 4, seed=3, out=str(out), max_workers=1)
    # recompute from the records by hand
    results = [json.loads(line)["result"] for line in out.read_text().splitlines()]
    st = rep["statistics"]
    assert st == statistics(results, 16)
    for c, d, m, e in zip(st["contacts"], st["dns"], st["map"], st["rel_error"]):
        k = results[0]["contacts"].index(c)
        live = [r for r in results if r["peaks"][k] is not None]
        assert d["n"] == len(live) <= 4
        if len(live) >= 2:
            dns = np.array([r["peaks"][k] for r in live])
            assert d["mean"] == pytest.approx(dns.mean(), rel=1e-14)
            assert d["std"] == pytest.approx(dns.std(ddof=1), rel=1e-12)
            errs = np.array([abs(r["map_peaks"][k] - r["peaks"][k]) / r["peaks"][k] for r in live
                             if r["map_peaks"][k] is not None])
            assert e["mean"] == pytest.approx(errs.mean(), rel=1e-12)
    # the realisations differ: the spread is real
    assert st["dns"][2]["std"] > 0
    assert st["rms_pct"]["mean"] == pytest.approx(np.mean([row["rms_pct"] for row in st["realisations"]]), rel=1e-12)


def test_a_larger_ensemble_reuses_the_recorded_realisations(tmp_path):
    out = str(tmp_path / "e.jsonl")
    ensemble(_scene(20), 2, seed=5, out=out, max_workers=1)
    rep = ensemble(_scene(20), 3, seed=5, out=out, max_workers=1)
    assert (rep["sweep"]["skipped"], rep["sweep"]["computed"]) == (2, 1)


def test_ensemble_on_dask_equals_serial():
    pytest.importorskip("dask")
    distributed = pytest.importorskip("distributed")
    sc = _scene(24)
    serial = ensemble(sc, 2, seed=1, max_workers=1)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        dask = ensemble(sc, 2, seed=1, executor=client.get_executor())
    assert dask["statistics"] == serial["statistics"]


def test_scene_without_random_parameter_and_bad_counts_are_refused():
    with pytest.raises(EnsembleError, match="no random parameter"):
        ensemble_points(load_scene("vdp-mu3-v2.3"), 2, 0)
    with pytest.raises(EnsembleError, match="realisations"):
        ensemble_points(_scene(), 0, 0)


def test_cli_ensemble(tmp_path, capsys):
    from pulsemap.solvers.cli.main import main

    out = tmp_path / "e.json"
    assert main(["ensemble", FIG13, "--realisations", "2", "--seed", "4", "--contacts", "16", "24",
                 "--workers", "1", "--quiet", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["realisations"] == 2 and len(data["derived_seeds"]) == 2
    assert "ensemble of 2 realisations" in capsys.readouterr().out
    assert main(["ensemble", "vdp-mu3-v2.3", "--realisations", "2", "--quiet"]) == 2
    assert "no random parameter" in capsys.readouterr().err


def test_cli_on_a_dask_scheduler(capsys):
    distributed = pytest.importorskip("distributed")
    from pulsemap.solvers.cli.main import main

    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        assert main(["ensemble", FIG13, "--realisations", "2", "--contacts", "16", "22", "--quiet",
                     "--scheduler", cluster.scheduler_address]) == 0
    assert "ensemble of 2 realisations" in capsys.readouterr().out
