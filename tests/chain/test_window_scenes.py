"""The moving window's accuracy rule checked scene by scene: on every built-in
and suite scene, the window sized by rule_for_accuracy(a) gives the full chain's peaks to within a,
for `run`'s default a = 1e-8 and for 1e-6 (what rtol 1e-6 asks for), with both integrated far
tighter (rtol 1e-12), so the difference is the window's truncation."""

from __future__ import annotations

import pytest

from pulsemap.solvers.chain.window import WindowSpec
from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.data.scene import builtin_scenes, load_scene
from pulsemap.solvers.data.scene.files import suite_scene_names
from pulsemap.solvers.studies.scene_chain import make_force
from pulsemap.solvers.studies.extent import dns_span

ACCURACIES = (1e-8, 1e-6)  # simulate's default for rtol <= 1e-8 (the rule `run` uses), and for rtol 1e-6
#: chain10000's full-chain reference alone costs ~190 s (10,000 beads): the window against the full
#: chain over 120 contacts is what the others check; its 10,000-contact run is checked by the suite.
EXPENSIVE = {"chain10000"}
SCENES = sorted(set(builtin_scenes()) | set(suite_scene_names()) - EXPENSIVE)


@pytest.mark.parametrize("name", SCENES)
def test_the_window_rule_holds_on_every_scene(name):
    sc = load_scene(name)
    beads, span = dns_span(sc)
    force = None if (sc.perturbation.R == 0 or sc.perturbation.eps == 0) else make_force(sc, beads)
    tight = Integrator(rtol=1e-12, atol=1e-14)
    full = simulate(Chain(beads, sc.exponent, sc.velocity, force), span, integrator=tight)
    ref = {c: p for c, p, a in zip(full.contacts, full.peaks, full.alive) if a}
    assert full.mode == "full" and ref, "no live contact: nothing to compare"
    for accuracy in ACCURACIES:
        win = simulate(Chain(beads, sc.exponent, sc.velocity, force), span,
                       integrator=tight, window=WindowSpec(accuracy=accuracy))
        got = {c: p for c, p, a in zip(win.contacts, win.peaks, win.alive) if a}
        assert win.mode.startswith("window")
        assert set(got) == set(ref), f"the window for {accuracy:g} changed where the pulse dies"
        worst = max(abs(got[c] / ref[c] - 1) for c in ref)
        assert worst < accuracy, f"window for {accuracy:g}: {worst:.2e}"
