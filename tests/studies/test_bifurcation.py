"""Stationary shocks in a parameter: Eq. 41 branches, fold, DNS outcomes and thresholds."""

import json
import math

import pytest

from pulsemap.solvers.studies.bifurcation import (
    BifurcationError, bifurcation, bracket, classify, predict, predicted_threshold, stable_peak,
)
from pulsemap.solvers.studies.points import dns_task, plain_chain
from pulsemap.solvers.data.scene import load_scene, with_overrides

VDP_SCENE = "vdp-mu3-v2.3"


def _result(peaks, stop="last contact peaked", first=15):
    contacts = list(range(first, first + len(peaks)))
    live = [c for c, p in zip(contacts, peaks) if p is not None]
    return {"contacts": contacts, "peaks": peaks, "alive_to": live[-1] if live else None, "stop_reason": stop}


def test_classify_settles_decays_or_undecided():
    steady = [1.0 - 0.5 * (1 - math.exp(-k / 10)) for k in range(200)]
    out = classify(_result(steady), settle_window=50, settle_tol=1e-3)
    assert out.kind == "settles" and out.amplitude == steady[-1] and abs(out.drift) < 1e-3
    drifting = [1.0 - 0.001 * k for k in range(200)]
    assert classify(_result(drifting), 50, 1e-3).kind == "undecided"
    died = [1.0 - 0.004 * k for k in range(150)] + [None] * 50
    out = classify(_result(died, "pulse died at contact 164 (peak below ...)"), 50, 1e-3)
    assert out.kind == "decays" and out.amplitude is None and out.alive_to == 15 + 149
    # lost for another reason than death (e.g. t_max): not called a decay
    assert classify(_result(died, "t_max reached (t=1)"), 50, 1e-3).kind == "undecided"
    assert classify(_result([1.0] * 20), 50, 1e-3).kind == "undecided"  # chain shorter than the window


def test_bracket_takes_the_smallest_settling_value_and_the_decay_below_it():
    rows = [{"value": v, "outcome": o} for v, o in
            [(1.0, "decays"), (1.2, "decays"), (1.4, "undecided"), (1.6, "settles"), (1.8, "settles")]]
    assert bracket(rows) == (1.2, 1.6)
    assert bracket([{"value": 1.0, "outcome": "settles"}]) == (None, 1.0)
    assert bracket([{"value": 1.0, "outcome": "decays"}]) == (1.0, None)


@pytest.fixture(scope="module")
def predictions():
    sc = load_scene(VDP_SCENE)
    return sc, {p: predict(sc, "mu", 1.0, 4.0, 31, p) for p in ("exact", "pade")}


def test_predicted_branches_fold_and_stability(predictions):
    from pulsemap.solvers.models.codeload import map_module

    sc, preds = predictions
    for prof, pred in preds.items():
        (fold,) = pred["folds"]
        mod = map_module(sc.perturbation.text, ["mu"], 1.5, prof, "1d")
        phi, dphi = mod.stationary(fold["A"], fold["value"])  # a double root of Eq. 41 there
        assert abs(phi) < 1e-10 and abs(dphi) < 1e-8
        assert 1.4 < fold["value"] < 1.5
        for b in pred["branches"]:
            if b["value"] < fold["value"]:
                assert b["roots"] == []
            else:  # lower root unstable (multiplier > 1), upper stable, around the fold's amplitude
                low, high = b["roots"]
                assert low["stable"] is False and low["multiplier"] > 1
                assert high["stable"] is True and 0 < high["multiplier"] < 1
                assert low["peak"] < fold["peak"] < high["peak"]
    # exact and Pade profiles: folds within 0.1 %
    assert preds["pade"]["folds"][0]["value"] == pytest.approx(preds["exact"]["folds"][0]["value"], rel=1e-3)


def test_predicted_threshold_of_an_impulse(predictions):
    from pulsemap.solvers.models.codeload import map_module
    from pulsemap.solvers.models.stationary_shock import roots

    sc, preds = predictions
    pred = preds["exact"]
    fold = pred["folds"][0]
    # an entry peak above the fold's amplitude survives from the fold on
    assert predicted_threshold(sc, "mu", pred, 1.4) == fold["value"]
    # below it: where the unstable root comes down to the entry peak
    t = predicted_threshold(sc, "mu", pred, 0.2)
    assert t > fold["value"]
    mod = map_module(sc.perturbation.text, ["mu"], 1.5, "exact", "1d")
    assert min(roots(mod, {"mu": t})) * mod.S0 == pytest.approx(0.2, rel=1e-8)
    assert predicted_threshold(sc, "mu", pred, 1e-4) is None  # not within mu <= 4
    sp = stable_peak(pred, 3.0)
    assert sp == pytest.approx(max(roots(mod, {"mu": 3.0})) * mod.S0, rel=1e-12)


def test_bad_parameter_and_range_are_one_line_errors():
    sc = load_scene(VDP_SCENE)
    with pytest.raises(BifurcationError, match="not a parameter"):
        bifurcation(sc, "nu", 1.0, 2.0)
    with pytest.raises(BifurcationError, match="A < B"):
        bifurcation(sc, "mu", 2.0, 1.0)
    fig13 = load_scene("fig13-seed1")
    with pytest.raises(BifurcationError, match="varies along the chain"):
        bifurcation(fig13, "k", 0.0, 1.0)


def test_bad_chain_and_impulses_are_reported_before_the_prediction(monkeypatch):
    import pulsemap.solvers.studies.bifurcation as bif

    def no_predict(*args, **kwargs):
        raise AssertionError("predict() ran before the DNS options were checked")

    monkeypatch.setattr(bif, "predict", no_predict)
    sc = load_scene(VDP_SCENE)
    with pytest.raises(BifurcationError, match="must lie beyond first_perturbed"):
        bifurcation(sc, "mu", 1.0, 2.0, last=sc.first_perturbed)
    with pytest.raises(BifurcationError, match="impulses are velocities"):
        bifurcation(sc, "mu", 1.0, 2.0, impulses=[2.3, -1.0])
    with pytest.raises(AssertionError, match="predict"):  # prediction only: the chain is not checked
        bifurcation(sc, "mu", 1.0, 2.0, last=sc.first_perturbed, dns=False)


def test_dns_outcomes_on_a_short_chain(tmp_path):
    """mu = 3 settles on the stable root; mu = 1 (no stationary shock) decays."""
    sc = load_scene(VDP_SCENE)
    rep = bifurcation(sc, "mu", 1.0, 3.0, points=2, impulses=[2.3], last=110, refine=0, predict_points=5,
                      profiles=("exact",), out=str(tmp_path / "b.jsonl"), max_workers=1)
    json.dumps(rep)
    low, high = sorted(rep["dns"]["points"], key=lambda r: r["value"])
    assert low["outcome"] == "decays" and low["amplitude"] is None
    assert high["outcome"] == "settles"
    assert high["amplitude"] == pytest.approx(high["predicted_stable_peak_exact"], rel=0.01)
    (t,) = rep["dns"]["thresholds"]
    assert t["bracket"] == [1.0, 3.0] and t["threshold"] == 2.0
    assert t["minus_fold"]["exact"] == pytest.approx(2.0 - rep["prediction"]["exact"]["folds"][0]["value"])


def test_cli_bifurcation_retry_failed_reruns_recorded_errors(tmp_path):
    """A point recorded with an error stays failed on a rerun, and is run again with --retry-failed."""
    from pulsemap.solvers.cli.main import main
    from pulsemap.solvers.data.records import encode_record, read_keyed

    out, rep_path = tmp_path / "b.jsonl", tmp_path / "rep.json"
    argv = ["bifurcation", VDP_SCENE, "--param", "mu", "--range", "1", "3", "--points", "2", "--impulses", "2.3",
            "--contacts", "110", "--refine", "0", "--predict-points", "5", "--profiles", "exact", "--workers", "1",
            "--quiet", "--out", str(out), "--json", str(rep_path)]
    assert main(argv) == 0
    recs = [json.loads(line) for line in out.read_text().splitlines()]
    assert len(recs) == 2 and all(r["status"] == "ok" for r in recs)
    low = min(recs, key=lambda r: r["params"]["params"]["mu"])
    bad = {**{k: v for k, v in low.items() if k not in ("result", "sha256")}, "status": "error",
           "error": "RuntimeError: injected"}
    with out.open("a") as fh:
        fh.write(encode_record(bad) + "\n")  # a failed point as the sweep records it, with its digest
    assert read_keyed(out)[low["key"]]["status"] == "error"

    def outcomes():
        rep = json.loads(rep_path.read_text())
        return rep["sweeps"][0]["computed"], {r["value"]: r["outcome"] for r in rep["dns"]["points"]}

    assert main(argv) == 0
    assert outcomes() == (0, {1.0: "failed", 3.0: "settles"})
    assert main(argv + ["--retry-failed"]) == 0
    assert outcomes() == (1, {1.0: "decays", 3.0: "settles"})


@pytest.mark.slow
def test_dns_stationary_amplitude_at_mu3_equals_the_stable_root():
    """Both impulses settle on one amplitude, within 0.5 % of Eq. 41's stable root (both profiles),
    and the DNS amplitude is converged in its tolerance."""
    sc = with_overrides(load_scene(VDP_SCENE), contacts=(16, 200))
    base = plain_chain(sc, window="auto", rtol=1e-8)
    amps = {}
    for v0, rtol in ((2.3, 1e-8), (0.3, 1e-8), (2.3, 1e-10)):
        out = classify(dns_task({**base, "velocity": v0, "dns": {**base["dns"], "rtol": rtol}}))
        assert out.kind == "settles"
        amps[(v0, rtol)] = out.amplitude
    assert amps[(2.3, 1e-8)] == pytest.approx(amps[(2.3, 1e-10)], rel=1e-6)
    assert amps[(0.3, 1e-8)] == pytest.approx(amps[(2.3, 1e-8)], rel=1e-4)
    for prof in ("exact", "pade"):
        stable = stable_peak(predict(sc, "mu", 2.9, 3.1, 3, prof), 3.0)
        assert amps[(2.3, 1e-8)] == pytest.approx(stable, rel=5e-3)
        print(f"mu = 3: DNS settles at {amps[(2.3, 1e-8)]:.6f} (v0 2.3) / {amps[(0.3, 1e-8)]:.6f} (v0 0.3); "
              f"Eq. 41 stable root ({prof}) {stable:.6f}")


@pytest.mark.slow
def test_van_der_pol_threshold_by_dns_sweep(tmp_path):
    """The DNS threshold lies between mu = 1.6 and 1.7 for both impulses (paper: 1.65), well above
    the predicted fold (1.468): at mu = 1.5 Eq. 41 has a stable shock that both entry peaks lie
    above the unstable root of, yet both pulses decay; from 1.7 on both impulses settle on one
    amplitude."""
    sc = load_scene(VDP_SCENE)
    rep = bifurcation(sc, "mu", 1.4, 1.8, points=5, impulses=[2.3, 0.3], last=400, refine=1, predict_points=31,
                      profiles=("exact",), out=str(tmp_path / "vdp.jsonl"), max_workers=2)
    pred = rep["prediction"]["exact"]
    fold = pred["folds"][0]["value"]
    for t in rep["dns"]["thresholds"]:
        a, b = t["bracket"]
        assert 1.6 - 1e-12 <= a < b <= 1.7 + 1e-12, t
        assert t["predicted"]["exact"] < 1.5  # the map says: survives at mu = 1.5
        assert a > fold + 0.1
    rows = {(r["v0"], round(r["value"], 6)): r for r in rep["dns"]["points"]}
    assert rows[(2.3, 1.5)]["outcome"] == rows[(0.3, 1.5)]["outcome"] == "decays"
    assert rows[(2.3, 1.8)]["outcome"] == rows[(0.3, 1.8)]["outcome"] == "settles"
    assert rows[(2.3, 1.8)]["amplitude"] == pytest.approx(rows[(0.3, 1.8)]["amplitude"], rel=1e-4)
    print(f"DNS threshold brackets: {[t['bracket'] for t in rep['dns']['thresholds']]}; predicted fold {fold:.6f}")


def test_cli_bifurcation_prediction_only(tmp_path, capsys):
    from pulsemap.solvers.cli.main import main

    out = tmp_path / "b.json"
    assert main(["bifurcation", VDP_SCENE, "--param", "mu", "--range", "1", "4", "--no-dns",
                 "--predict-points", "31", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert set(data["prediction"]) == {"exact", "pade"}
    assert "predicted fold (exact profile" in capsys.readouterr().out
    assert main(["bifurcation", VDP_SCENE, "--param", "mu", "--range", "1", "4", "--profiles", "exakt"]) == 2
    assert "unknown profile" in capsys.readouterr().err


def test_plot_like_fig12(tmp_path):
    pytest.importorskip("matplotlib")
    from pulsemap.solvers.studies.bifurcation import plot

    sc = load_scene(VDP_SCENE)
    rep = bifurcation(sc, "mu", 1.0, 4.0, predict_points=11, dns=False)
    path = tmp_path / "f.png"
    plot(rep, str(path))
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
