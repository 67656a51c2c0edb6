"""Scenes with a contact law's term or masses run from Python as a user would: the first-order energy law
against the project's own DNS, the measure of the targets (RMS of (law - DNS) / entry peak over the contacts
where the law keeps >= 10 % of the entry peak, seeded at contact 15), and the models that refuse say why."""

from __future__ import annotations

import numpy as np
import pytest

import pulsemap


def scene(contact=None, masses=None, R=None, last=100, methods=("dns", "energy-law")):
    data = {"name": "contact-test", "excitation": {"velocity": 1.0},
            "output": {"contacts": [16, last], "methods": list(methods)}}
    for key, table in (("contact", contact), ("masses", masses), ("perturbation", R)):
        if table is not None:
            data[key] = table
    return pulsemap.scene(data)


def law_error(result, model: str = "energy-law") -> float:
    dns = np.array([np.nan if p is None else p for p in result.peaks["dns"]], float)
    law = np.array([np.nan if p is None else p for p in result.peaks[model]], float)
    entry = dns[0]
    kept = law >= 0.1 * entry
    assert kept.sum() > 20
    return float(np.sqrt(np.mean(((law - dns) / entry)[kept] ** 2)))


@pytest.mark.parametrize("contact, R, masses, bound", [
    ({"P": "gamma*w", "eps": 0.02, "params": {"gamma": 1.0}}, None, None, 0.035),
    ({"P": "d^(1/2)*w", "eps": 0.05}, None, None, 0.03),
    ({"P": "w", "eps": 0.01}, {"R": "-v", "eps": 0.01}, None, 0.012),
    ({"P": "w", "eps": 0.01}, None, {"m": "1 + 0.003*(i - 16)"}, 0.013),
    ({"P": "d^(1/2)*w", "eps": 0.03}, {"R": "-u", "eps": 0.01}, None, 0.008),
], ids=["dashpot", "kuwabara-kono", "dashpot+damping", "dashpot-on-taper", "kk+foundation"])
def test_the_energy_law_follows_the_dns(contact, R, masses, bound):
    result = pulsemap.run(scene(contact, masses, R))
    assert result.peaks["dns"][-1] < 0.95 * result.peaks["dns"][0]  # the contact term damps the pulse
    assert law_error(result) <= bound


def test_the_energy_map_and_law_agree_to_first_order():
    result = pulsemap.run(scene({"P": "w", "eps": 0.01}, methods=("dns", "energy-law", "energy-map")))
    law = np.array(result.peaks["energy-law"], float)
    step = np.array(result.peaks["energy-map"], float)
    assert np.max(np.abs(step / law - 1.0)) < 0.01


def test_a_taper_keeps_the_strain_peak_and_gives_bead_velocity_peaks():
    """Masses alone do no work: the strain peak stays within a few tenths of a percent of the entry while
    the masses grow by half; the law's bead-velocity peaks fall as m^(-1/2)."""
    result = pulsemap.run(scene(masses={"m": "1 + 0.004*(i - 16)"}, last=140))
    dns = np.array(result.peaks["dns"], float)
    assert np.max(np.abs(dns / dns[0] - 1.0)) < 0.01
    assert law_error(result) < 0.005
    vel = result.data["energy-law"]["velocity_peaks"]
    beads, peaks = np.array(vel["beads"]), np.array(vel["peaks"], float)
    m = np.maximum(1 + 0.004 * (beads - 16), 1.0)
    ratio = peaks * np.sqrt(m)
    assert peaks[-1] < 0.85 * peaks[0]
    assert np.ptp(ratio[beads > 20]) / ratio[-1] < 0.01
    measured = result.data["dns"]["velocity_peaks"]  # the DNS's own bead velocity maxima
    law_at = dict(zip(vel["beads"], vel["peaks"]))
    pairs = np.array([(law_at[b], p) for b, p in zip(measured["beads"], measured["peaks"]) if b in law_at], float)
    assert len(pairs) > 100
    assert np.sqrt(np.mean((pairs[:, 0] / pairs[:, 1] - 1.0) ** 2)) < 0.002


def test_models_derived_for_an_onsite_force_refuse_a_contact_term_naming_what_runs_it():
    result = pulsemap.run(scene({"P": "w", "eps": 0.01}, methods=("dns", "map", "longwave")))
    assert result.peaks.get("map") is None and result.data["map"]["refused"]
    assert any("energy-law" in w and "map refused" in w for w in result.warnings)


def test_an_elastic_correction_keeps_the_plateau_the_law_transmits():
    """c d^(n+1) does no work: after the entry jump the DNS peaks settle on the plateau the energy law (with its
    entry-jump constant) transmits, within 1e-3 in ln P."""
    result = pulsemap.run(scene({"P": "d^(5/2)", "eps": 0.1}, last=100))
    dns = np.array(result.peaks["dns"], float)
    law = np.array(result.peaks["energy-law"], float)
    plateau = slice(14, None)  # contacts 30..100, past the entry transient
    assert np.ptp(law[plateau]) == 0.0
    assert np.sqrt(np.mean(np.log(law[plateau] / dns[plateau]) ** 2)) < 1e-3
    assert law[0] > dns[0] * 1.005  # a stiffer contact raises the peak (the jump) ...
    assert abs(law[0] / result.data["seed"]["peak"] - 1) > 0.005  # ... which the law carries


def test_relaxed_takes_a_uniform_contact_term_and_beats_the_first_order_law():
    """The relaxed map built from segment runs of the same contact law (no scene data), over the contacts where the
    DNS peak keeps >= 10 % of the entry peak: within 2 % on a dashpot at eps c 0.035 (the first-order law is off by
    tens of percent there) and on a Kuwabara-Kono contact."""
    for contact, last in (({"P": "w", "eps": 0.035}, 160), ({"P": "d^(1/2)*w", "eps": 0.05}, 120)):
        result = pulsemap.run(scene(contact, last=last, methods=("dns", "energy-law", "relaxed")))
        assert result.data["relaxed"]["status"] == "ok"
        dns = np.array([np.nan if p is None else p for p in result.peaks["dns"]], float)
        kept = dns >= 0.1 * dns[0]
        errors = {}
        for model in ("relaxed", "energy-law"):
            peaks = np.array([np.nan if p is None else p for p in result.peaks[model]], float)
            errors[model] = np.sqrt(np.mean(((peaks - dns) / dns)[kept] ** 2))
        assert errors["relaxed"] < 0.02 and 5 * errors["relaxed"] < errors["energy-law"], errors


def test_relaxed_refuses_masses_with_a_contact_term_and_a_graded_contact_term_naming_what_runs_them():
    result = pulsemap.run(scene({"P": "w", "eps": 0.01}, masses={"m": 1.2}, methods=("dns", "relaxed")))
    assert "energy-law" in result.data["relaxed"]["refused"]
    graded = pulsemap.run(scene({"P": "(1 + 0.01*k)*w", "eps": 0.01}, methods=("dns", "relaxed")))
    assert "varies along the chain" in graded.data["relaxed"]["refused"]
    graded_r = pulsemap.run(scene({"P": "w", "eps": 0.01}, R={"R": "-(1 + 0.01*i)*u", "eps": 0.01},
                                  methods=("relaxed",), last=40))
    assert "varies along the chain" in graded_r.data["relaxed"]["refused"]  # R with the bead index i too


def _random_masses(seed: int) -> dict:
    half = 3.0 ** 0.5  # xi uniform of unit variance
    return {"m": "1 + 0.1*xi", "params": {"xi": {"uniform": [-half, half], "seed": seed}}}


def test_relaxed_follows_random_masses_with_its_kernel_in_the_local_masses():
    """m_i = 1 + 0.1 xi_i: peaks jump by several percent from contact to contact and their mean falls (second
    order); the kernel fitted to the model's own calibration chains follows an unseen draw within 1 % RMS in ln P
    over 270 contacts, where the first-order law (constant strain) is off by about ten times that."""
    data = {"name": "random-masses", "chain": {"beads": 300}, "excitation": {"velocity": 1.0},
            "masses": _random_masses(7), "output": {"contacts": [16, 285], "methods": ["dns", "energy-law", "relaxed"]}}
    result = pulsemap.run(pulsemap.scene(data))
    dns = np.log(np.array(result.peaks["dns"], float))
    assert np.std(np.diff(dns)) > 0.02  # the peaks do jump
    relaxed = np.log(np.array(result.peaks["relaxed"], float))
    law = np.log(np.array(result.peaks["energy-law"], float))
    err = np.sqrt(np.mean((relaxed - dns) ** 2))
    assert err < 0.01 and 5 * err < np.sqrt(np.mean((law - dns) ** 2))
    assert 0 < result.data["relaxed"]["bulk_accuracy_log_ratio"] < 0.01


def test_the_mass_kernel_leaves_a_uniform_mass_alone_and_follows_a_taper():
    """sum K_j = 0 and no mass steps: a chain of uniform mass 1.7 keeps the seed peak exactly; on a taper the kernel
    is closer to the DNS than the constant strain of the first-order law."""
    from pulsemap.solvers.models.mass_kernel import kernel_peaks, mass_kernel

    kernel = mass_kernel(1.5)
    assert abs(sum(kernel.K)) < 1e-12
    contacts, peaks = kernel_peaks(kernel, np.full(200, 1.7), 0.74, 15, 180)
    assert np.allclose(peaks, 0.74, rtol=0, atol=1e-15) and contacts[0] == 16
    result = pulsemap.run(scene(masses={"m": "1 + 0.007*(i - 16)"}, last=200, methods=("dns", "energy-law", "relaxed")))
    dns = np.log(np.array(result.peaks["dns"], float))
    relaxed = np.log(np.array(result.peaks["relaxed"], float))
    law = np.log(np.array(result.peaks["energy-law"], float))
    assert np.sqrt(np.mean((relaxed - dns) ** 2)) < 0.5 * np.sqrt(np.mean((law - dns) ** 2))


def _ensemble_scene(contact=None, last=50):
    data = {"name": "random-masses-ensemble", "excitation": {"velocity": 1.0}, "masses": _random_masses(7),
            "output": {"contacts": [16, last], "methods": ["dns"]}}
    if contact is not None:
        data["contact"] = contact
    return pulsemap.scene(data)


def test_an_ensemble_of_random_masses_runs_each_realisation_as_run_does(tmp_path):
    """Realisation j is the scene with the draw's seed derived_seed(seed, j, 0): its DNS, energy-law and relaxed
    peaks are run's for that seed, bit for bit, and the per-contact statistics are those of the records."""
    import json

    from pulsemap.solvers.data.scene.overrides import with_sets
    from pulsemap.solvers.studies.ensemble import derived_seed, ensemble, to_text
    from pulsemap.solvers.studies.run import run_scene

    sc = _ensemble_scene()
    out = tmp_path / "e.jsonl"
    rep = ensemble(sc, 3, seed=5, out=str(out), max_workers=1)
    json.dumps(rep)
    assert rep["failed"] == [] and rep["derived_seeds"][2] == {"masses.params.xi": derived_seed(5, 2, 0)}
    results = [json.loads(line)["result"] for line in out.read_text().splitlines()]
    half = 3.0 ** 0.5
    ref = run_scene(with_sets(sc, [("masses.params.xi", {"uniform": [-half, half], "seed": derived_seed(5, 2, 0)})]),
                    methods=["dns", "energy-law", "relaxed"])
    for method in ("dns", "energy-law", "relaxed"):
        assert results[2]["peaks"][method] == ref["peaks"][method]
    assert results[2]["errors"] == ref["errors"]
    assert results[0]["peaks"]["dns"] != results[1]["peaks"]["dns"]  # different draws, different chains
    st = rep["statistics"]
    for k in (0, 17, len(st["contacts"]) - 1):
        dns = np.array([r["peaks"]["dns"][k] for r in results])
        assert st["dns"][k]["mean"] == pytest.approx(dns.mean(), rel=1e-14)
        assert st["dns"][k]["std"] == pytest.approx(dns.std(ddof=1), rel=1e-12)
        law = np.array([r["peaks"]["energy-law"][k] for r in results])
        assert st["models"]["energy-law"]["rel_error"][k]["mean"] == pytest.approx(np.mean(np.abs(law / dns - 1)))
    rms = [r["errors"]["relaxed"]["rms_pct"] for r in results]
    assert st["models"]["relaxed"]["rms_pct"]["mean"] == pytest.approx(np.mean(rms))
    assert st["models"]["relaxed"]["rms_pct"]["max"] < 1.0  # percent: the mass kernel follows each draw
    assert st["models"]["relaxed"]["rms_pct"]["mean"] < 0.5 * st["models"]["energy-law"]["rms_pct"]["mean"]
    assert len(st["velocity_peaks"]["beads"]) == len(st["contacts"]) and st["velocity_peaks"]["dns"][0]["n"] == 3
    assert "relaxed" in to_text(rep) and "masses.params.xi" in to_text(rep)


def test_an_ensembles_dns_is_the_chain_of_its_drawn_masses():
    """Independently of the scene machinery: masses 1 + 0.1 xi with xi = default_rng(seed).uniform(-sqrt 3, sqrt 3)
    over the chain's beads (bead i is element i - 1, from bead 16 on), integrated on the scipy full chain, give the
    realisation's DNS peaks."""
    from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
    from pulsemap.solvers.studies.ensemble import derived_seed
    from pulsemap.solvers.studies.terms_ensemble import terms_points, terms_task
    from pulsemap.solvers.studies.extent import dns_span

    sc = _ensemble_scene(last=40)
    point = terms_points(sc, 2, 9)[1]
    got = terms_task(point)
    beads, span = dns_span(sc)
    half = 3.0 ** 0.5
    xi = np.random.default_rng(derived_seed(9, 1, 0)).uniform(-half, half, beads)
    masses = np.where(np.arange(1, beads + 1) >= 16, 1 + 0.1 * xi, 1.0)
    ref = simulate(Chain(beads, 1.5, 1.0, masses=masses), (16, 40),
                   integrator=Integrator(method="DOP853", rtol=1e-11, atol=1e-13, engine="scipy"))
    np.testing.assert_allclose(got["peaks"]["dns"], ref.peaks, rtol=1e-7)


def test_an_ensemble_with_a_contact_term_and_random_masses_says_which_models_run():
    """A dashpot with a random coefficient on random masses: two draws with their own derived seeds; the energy law
    runs, relaxed is refused with its reason in the report."""
    from pulsemap.solvers.studies.ensemble import derived_seed, ensemble
    from pulsemap.solvers.studies.terms_ensemble import drawn_keys

    contact = {"P": "g*w", "eps": 0.01, "params": {"g": {"uniform": [0.5, 1.5], "seed": 1}}}
    sc = _ensemble_scene(contact, last=40)
    assert drawn_keys(sc) == [("contact", "params", "g"), ("masses", "params", "xi")]
    rep = ensemble(sc, 2, seed=4, max_workers=1)
    assert rep["derived_seeds"][1] == {"contact.params.g": derived_seed(4, 1, 0),
                                       "masses.params.xi": derived_seed(4, 1, 1)}
    models = rep["statistics"]["models"]
    assert models["energy-law"]["refused"] is None and models["energy-law"]["rms_pct"]["n"] == 2
    assert "no relaxed model" in models["relaxed"]["refused"] and models["relaxed"]["rms_pct"]["n"] == 0
    dns = [s["mean"] for s in rep["statistics"]["dns"]]
    assert dns[-1] < dns[0]  # the dashpot damps the pulse


def test_an_ensemble_needs_a_random_draw_naming_random_masses():
    from pulsemap.solvers.studies.ensemble import EnsembleError, ensemble

    with pytest.raises(EnsembleError, match=r"random masses \[masses\] m = \{uniform"):
        ensemble(scene(masses={"m": 1.2}), 2)


@pytest.mark.parametrize("n, slope", [(1.5, 0.007), (1.5, 0.003), (1.5, -0.003), (2.5, 0.007), (2.5, -0.003)])
def test_relaxed_follows_a_taper_on_the_full_chain_dns(n, slope):
    """m_i = 1 + slope (i - 16), contacts 16..290 (m reaches 2.9 at 0.007, falls to 0.18 at -0.003), against the
    full-chain DNS: relaxed (the mass kernel with its slow part, calibrated on other slopes and on exponential
    tapers) within 2e-4 RMS in ln P of the strain peaks, ten times closer than the constant strain of the first-order
    taper law, and its bead velocity peaks within 0.2 % RMS of the DNS's."""
    from pulsemap.solvers.models.mass_kernel import SMOOTH_CALIBRATION

    assert slope not in [rate for _, rate in SMOOTH_CALIBRATION]
    data = {"name": "taper", "chain": {"beads": 300, "exponent": n}, "excitation": {"velocity": 1.0},
            "dns": {"mode": "full"},
            "masses": {"m": f"1 + {slope}*(i - 16)"},
            "output": {"contacts": [16, 290], "methods": ["dns", "energy-law", "relaxed"]}}
    result = pulsemap.run(pulsemap.scene(data))
    assert result.data["dns"]["mode"] == "full"
    dns = np.log(np.array(result.peaks["dns"], float))
    errors = {m: np.sqrt(np.mean((np.log(np.array(result.peaks[m], float)) - dns) ** 2)) for m in ("relaxed", "energy-law")}
    assert errors["relaxed"] < 2e-4 and 10 * errors["relaxed"] < errors["energy-law"], errors
    model = dict(zip(*(result.data["relaxed"]["velocity_peaks"][k] for k in ("beads", "peaks"))))
    measured = result.data["dns"]["velocity_peaks"]
    pairs = np.array([(model[b], v) for b, v in zip(measured["beads"], measured["peaks"]) if b in model], float)
    assert len(pairs) > 250
    assert np.sqrt(np.mean((pairs[:, 0] / pairs[:, 1] - 1.0) ** 2)) < 0.002


def test_the_mass_kernels_slow_part_reads_the_gradient_its_loss_and_its_curvature():
    """On masses exp(g (i - 1)) every mass step is g: past the ends' reach G = g, G' = 0 and R grows by g^2 per
    contact; on a linear taper G' is the derivative of g = slope/m, -slope^2/m^2; uniform masses give zeros."""
    from pulsemap.solvers.models.mass_kernel import SMOOTH_HALF_WIDTH, _smooth_features

    g = 0.003
    beads = np.arange(1, 101)
    contacts = np.arange(20, 80)
    G, R, slope = _smooth_features(g * (beads - 1.0), contacts).T
    np.testing.assert_allclose(G, g, rtol=1e-12)
    np.testing.assert_allclose(slope, 0.0, atol=1e-15)
    np.testing.assert_allclose(np.diff(R), g * g, rtol=1e-10)
    m = 1 + 0.004 * (beads - 1.0)
    G, _, slope = _smooth_features(np.log(m), contacts).T
    mid = 0.5 * (m[contacts - 1] + m[contacts])  # contact k joins beads k and k + 1
    np.testing.assert_allclose(G, 0.004 / mid, rtol=3e-4)  # the box's bias h (h + 1) g''/(6 g), 1.4e-4 here
    np.testing.assert_allclose(slope, -(0.004 / mid) ** 2, rtol=2e-3)
    assert not np.any(_smooth_features(np.zeros(60), np.arange(1, 59)))
    assert SMOOTH_HALF_WIDTH >= 1


def test_the_ensemble_command_takes_random_masses(tmp_path, capsys):
    """`pulsemap ensemble` on a scene file with random masses: exit 0, strict JSON on stdout with the statistics of
    every model, the text report on stderr."""
    import json

    from pulsemap.solvers.cli.main import main

    path = tmp_path / "masses.toml"
    path.write_text('name = "random-masses"\n[excitation]\nvelocity = 1.0\n[masses]\nm = "1 + 0.1*xi"\n'
                    '[masses.params]\nxi = {uniform = [-1.7, 1.7], seed = 3}\n'
                    '[output]\ncontacts = [16, 30]\nmethods = ["dns"]\n')
    code = main(["ensemble", str(path), "--realisations", "2", "--workers", "1", "--quiet", "--json", "-"])
    captured = capsys.readouterr()
    assert code == 0, captured.err

    def refuse(token):
        raise AssertionError(f"non-standard JSON number {token}")

    report = json.loads(captured.out, parse_constant=refuse)
    assert set(report["statistics"]["models"]) == {"energy-law", "relaxed"}
    assert report["statistics"]["dns"][0]["n"] == 2 and "relaxed" in captured.err


def test_a_given_seed_peak_seeds_the_energy_law_of_a_contact_scene():
    """--seed-peak seeds the contact law's energy law and map as it seeds every model: the same peak, and the
    law's peaks grow with it (without DNS, from the seed alone)."""
    from pulsemap.solvers.studies.run import run_scene

    sc = scene({"P": "w", "eps": 0.02}, methods=("energy-law", "energy-map"), last=40)
    low, high = (run_scene(sc, seed_peak=p) for p in (0.5, 0.6))
    assert low["seed"]["peak"] == 0.5 and "given peak" in low["seed"]["from"]
    for m in ("energy-law", "energy-map"):
        a, b = np.array(low["peaks"][m], float), np.array(high["peaks"][m], float)
        assert np.all(np.isfinite(a)) and np.all(b > a)


def test_a_run_over_a_sharp_mass_step_says_it_took_the_full_chain():
    """An 'auto' window runs the full chain over masses that jump by more than window.MASS_STEP_LIMIT (a coasting
    dropped bead would drive the window like a piston): the run's JSON and report say so, with the ratio; a mild
    step keeps the moving window and says nothing."""
    from pulsemap.solvers.studies.run.report import to_text

    def run(m: str):
        data = {"name": "mass-step", "chain": {"beads": 140}, "excitation": {"velocity": 1.0}, "masses": {"m": m},
                "output": {"contacts": [16, 120], "methods": ["dns"]}}
        return pulsemap.run(pulsemap.scene(data))

    sharp, mild = run("1 + 2*Heaviside(i - 60)"), run("1 + 0.2*Heaviside(i - 60)")
    assert sharp.data["dns"]["mode"] == "full" and mild.data["dns"]["mode"].startswith("window")
    because = sharp.data["dns"]["full_chain_because"]
    assert "2x" in because and "1.5x" in because and "full_chain_because" not in mild.data["dns"]
    assert f"(the full chain: {because})" in to_text(sharp.data)
