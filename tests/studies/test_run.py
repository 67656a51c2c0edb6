"""Scene runs: DNS, map and long-wave law side by side (docs/design.rst, "The result of a run")."""

import json

import numpy as np
import pytest

import pulsemap.solvers.studies.run as run_mod
from pulsemap.solvers.studies.run import run_scene
from pulsemap.solvers.studies.run.report import to_csv
from pulsemap.solvers.data.scene import load_scene, with_overrides


def _small(name, last=40, **kw):
    return with_overrides(load_scene(name), contacts=(16, last), **kw)


def test_run_json_contract_and_seed_from_dns():
    res = run_scene(_small("fig8-eps0.1", 40))
    json.dumps(res)
    for key in ("scene", "contacts", "peaks", "errors", "timings_s"):
        assert key in res
    assert res["contacts"] == list(range(16, 41))
    for name in ("dns", "map", "longwave"):
        assert len(res["peaks"][name]) == 25
    assert res["seed"]["contact"] == 15 and res["seed"]["from"].startswith("DNS")
    assert res["choices"] == {"profile": "exact", "variant": "paper", "methods": ["map", "longwave", "dns"]}
    for name in ("map", "longwave"):
        err = res["errors"][name]
        assert err["compared"] > 0 and 0 <= err["rms_pct"] <= err["max_pct"] and err["unit"] == "percent"
    # errors recomputed from the peaks over the live range (DNS peak >= 2 % of the seed peak)
    d, m = np.array(res["peaks"]["dns"], float), np.array(res["peaks"]["map"], float)
    a, b = res["errors"]["map"]["live_range"]
    assert a == 16 and d[b - 16] >= 0.02 * res["seed"]["peak"] and not (d[b - 15:] >= 0.02 * res["seed"]["peak"]).any()
    ok = slice(a - 16, b - 15)
    assert res["errors"]["map"]["max_pct"] == pytest.approx(100 * np.max(np.abs(m[ok] - d[ok]) / d[ok]))
    assert set(res["timings_s"]) >= {"dns", "map", "longwave"}
    assert to_csv(res).splitlines()[0] == ("contact,dns,map,longwave,dns_alive,live_range,dns_arrival_time,dns_speed,"
                                           "dns_pulse_energy,dns_total_energy")


def test_law_only_scene_runs_no_dns(monkeypatch):
    def boom(*a, **k):
        raise AssertionError("the DNS ran although the scene did not ask for it")

    monkeypatch.setattr(run_mod, "simulate", boom)
    res = run_scene(_small("fig8-eps0.1", 60), methods=["longwave"])
    assert res["peaks"]["dns"] is None and res["peaks"]["map"] is None
    assert res["peaks"]["longwave"][0] is not None
    assert "kappa" in res["seed"]["from"]


def test_map_and_law_agree_with_each_other_for_small_eps():
    """The long-wave law is the continuum limit of the (1d) map: close for small eps."""
    res = run_scene(_small("fig7-eps0.1", 60), methods=["map", "longwave"], variant="1d")
    m = np.array(res["peaks"]["map"], float)
    lw = np.array(res["peaks"]["longwave"], float)
    assert np.max(np.abs(m - lw) / lw) < 0.05


def test_site_dependent_scene_solves_the_law_with_bead_coefficients():
    res = run_scene(_small("fig13-seed1", 30), methods=["map", "longwave"])
    assert res["peaks"]["longwave"][0] is not None
    assert res["longwave"]["kind"] == "quadrature (site-dependent)"
    assert not any("skipped" in w for w in res["warnings"])


def test_van_der_pol_mu3_both_impulses_approach_the_stable_root():
    from pulsemap.symbolic.derivation import derive_all

    finals = []
    for name in ("vdp-mu3-v2.3", "vdp-mu3-v0.3"):
        res = run_scene(_small(name, 90), methods=["dns", "map", "longwave"], variant="1d")
        dns = [p for p in res["peaks"]["dns"] if p is not None]
        finals.append(dns[-1])
    sc = load_scene("vdp-mu3-v2.3")
    roots = derive_all(sc.perturbation).stationary.peaks()
    stable = max(roots)
    assert finals[0] == pytest.approx(finals[1], rel=5e-3)
    assert finals[0] == pytest.approx(stable, rel=0.01)
    print(f"VdP mu=3: DNS settles at {finals[0]:.6f} / {finals[1]:.6f}; Eq. 41 stable root peak {stable:.6f}")


def test_van_der_pol_mu1_decays_while_the_primary_pulse_lives():
    res = run_scene(_small("vdp-mu1-v2.3", 60), methods=["dns"])
    dns = [p for p in res["peaks"]["dns"] if p is not None]
    assert len(dns) > 30
    assert all(b < a for a, b in zip(dns, dns[1:]))


def test_seed_from_a_given_peak_equals_seed_from_that_amplitude():
    from pulsemap.solvers.models.codeload import map_module
    from pulsemap.solvers.models.map_iteration import iterate_map

    res = run_scene(_small("fig8-eps0.1", 30), methods=["map"], seed_peak=0.7)
    assert res["seed"]["peak"] == 0.7 and "given" in res["seed"]["from"]
    mod = map_module("-mu*v", ["mu"], 1.5)
    direct = iterate_map(mod, 0.7 / mod.S0, 15, 30, 0.1, {"mu": 1.0})
    assert res["peaks"]["map"] == pytest.approx(list(direct.peaks), rel=1e-15)


def test_plot_in_the_papers_style(tmp_path):
    pytest.importorskip("matplotlib")
    from pulsemap.solvers.studies.run.report import plot

    res = run_scene(_small("fig8-eps0.1", 30), methods=["map", "longwave"])
    out = tmp_path / "p.png"
    plot(res, str(out))
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_reusing_a_dns_run_gives_the_same_errors_as_running_it():
    scene = _small("vdp-mu3-v2.3", 40)
    full = run_scene(scene, methods=["dns", "map", "longwave"])
    ref = run_scene(scene, methods=["dns"])
    again = run_scene(scene, methods=["map", "longwave"], reuse_dns=ref)
    assert again["seed"] == full["seed"]
    assert again["errors"] == full["errors"]


def test_run_uses_the_moving_window_unless_the_scene_asks_for_the_full_chain():
    """A run's DNS is windowed by default ([dns] mode = "window"); mode "full"
    integrates every bead; both give the same peaks to the window's accuracy rule (1e-8) plus the
    integrator's tolerance."""
    import numpy as np

    from pulsemap.solvers.data.scene.overrides import with_sets

    scene = with_sets(load_scene("fig8-eps0.1"), ["output.contacts=[16, 60]"])
    win = run_scene(scene, methods=["dns"])
    full = run_scene(with_sets(scene, ["dns.mode=full"]), methods=["dns"])
    assert win["dns"]["mode"].startswith("window") and win["dns"]["window_behind"] >= 2
    assert full["dns"]["mode"] == "full" and "window_behind" not in full["dns"]
    assert win["dns"]["window_beads"] < full["dns"]["window_beads"]
    a = np.array(win["peaks"]["dns"], float)
    b = np.array(full["peaks"]["dns"], float)
    assert np.max(np.abs(a / b - 1)) < 1e-7
    assert run_scene(scene, methods=["dns"], dns_window=None)["dns"]["mode"] == "full"


def test_a_misspelt_dns_mode_is_refused_with_the_choices():
    from pulsemap.solvers.data.scene.overrides import with_sets
    from pulsemap.solvers.data.scene import SceneError

    with pytest.raises(SceneError, match="mode 'wind'.*window, full"):
        with_sets(load_scene("fig8-eps0.1"), ["dns.mode=wind"])


def test_an_unperturbed_chain_warns_that_the_paper_map_drifts_and_the_corrected_one_is_constant():
    """R = 0: the DNS keeps the soliton (energy conserved), the corrected and 1d maps are constant,
    the paper's map drifts by its erratum and the run says so."""
    from pulsemap.solvers.data.scene.overrides import with_sets

    scene = with_sets(load_scene("fig8-eps0.1"), ["perturbation.R=0", "output.contacts=[16, 60]"])
    paper = run_scene(scene, methods=["map", "dns"])
    assert any("drifts even without perturbation" in w for w in paper["warnings"])
    dns = np.array(paper["peaks"]["dns"], float)
    # the soliton formed by the impact still settles by ~1e-5 over contacts 16..30; from 36 on it is steady
    assert np.ptp(dns[20:]) / dns.mean() < 1e-6 and paper["dns"]["energy_drift"] < 1e-6
    m = np.array(paper["peaks"]["map"], float)
    assert m[-1] < m[0] * (1 - 1e-3)  # the drift the warning names
    for variant in ("corrected", "1d"):
        other = run_scene(scene, methods=["map"], variant=variant)
        assert not any("drifts" in w for w in other["warnings"])
        peaks = np.array(other["peaks"]["map"], float)
        assert np.ptp(peaks) / peaks.mean() < 1e-12
