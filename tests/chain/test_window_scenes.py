"""The moving window's accuracy rule checked scene by scene (issue 19 item 1): on every built-in
and suite scene, `run`'s default DNS (the window sized by rule_for_accuracy(1e-8)) gives the full
chain's peaks to within that accuracy, with both integrated far tighter (rtol 1e-12), so the
difference is the window's truncation."""

from __future__ import annotations

import pytest

from pulsemap.solvers.chain.dns import simulate
from pulsemap.solvers.data.scene import builtin_scenes, load_scene
from pulsemap.solvers.data.scene_files import suite_scene_names
from pulsemap.solvers.studies.forcing import make_force
from pulsemap.solvers.studies.points import dns_span

WINDOW_ACCURACY = 1e-8  # simulate's default window_accuracy, the rule `run` uses
#: chain10000's full-chain reference alone costs ~190 s (10,000 beads): the window against the full
#: chain over 120 contacts is what the others check; its 10,000-contact run is checked by the suite.
EXPENSIVE = {"chain10000"}
SCENES = sorted(set(builtin_scenes()) | set(suite_scene_names()) - EXPENSIVE)


@pytest.mark.parametrize("name", SCENES)
def test_the_window_rule_holds_on_every_scene(name):
    sc = load_scene(name)
    beads, span = dns_span(sc)
    force = None if (sc.perturbation.R == 0 or sc.perturbation.eps == 0) else make_force(sc, beads)
    tight = dict(rtol=1e-12, atol=1e-14)
    full = simulate(beads, sc.exponent, sc.velocity, span, force, **tight)
    win = simulate(beads, sc.exponent, sc.velocity, span, force, window="auto", window_accuracy=WINDOW_ACCURACY,
                   **tight)
    ref = {c: p for c, p, a in zip(full.contacts, full.peaks, full.alive) if a}
    got = {c: p for c, p, a in zip(win.contacts, win.peaks, win.alive) if a}
    assert win.mode.startswith("window") and full.mode == "full"
    assert set(got) == set(ref), "the window changed where the pulse dies"
    assert ref, "no live contact: nothing to compare"
    worst = max(abs(got[c] / ref[c] - 1) for c in ref)
    assert worst < WINDOW_ACCURACY
