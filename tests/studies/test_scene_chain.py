"""A chain's force (solvers/models/chain_build.py, a scene's through solvers/studies/scene_chain.py): O(window)
per-bead data for a uniform R, the same force as on the whole chain, kept in-process, one random draw on both
sides, and one builder for every caller."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pulsemap

from pulsemap.symbolic.perturbation import make_perturbation
from pulsemap.solvers.models.chain_build import ChainSpec, build_force
from pulsemap.solvers.studies.scene_chain import make_force
from pulsemap.solvers.studies.points import bead_params
from pulsemap.solvers.models.codeload import force_module


def chain_force(module, chain, values):
    """The force of a plain chain through the one builder (not kept: each test sees its own build)."""
    spec = ChainSpec(chain["beads"], 1.5, 1.0, module.SOURCE["R"], tuple(module.PARAMS), values, chain["eps"],
                     chain["first_perturbed"])
    return build_force(spec, module, keep=False)


def _full_force(module, beads, fp, eps, values, x, v):
    """The force evaluated directly on the whole chain (the reference)."""
    i = np.arange(1, beads + 1, dtype=float)
    e = np.where(i >= fp, eps, 0.0)
    return module.force(x, v, i, e, *(values[p] for p in module.PARAMS))


def test_window_slices_match_the_whole_chain():
    mod = force_module("-(u - mu*(1 - u^2)*v)", ("mu",))
    beads, fp = 200, 16
    force = chain_force(mod, {"beads": beads, "first_perturbed": fp, "eps": 0.1}, {"mu": 3.0})
    rng = np.random.default_rng(1)
    x, v = rng.normal(size=beads), rng.normal(size=beads)
    ref = _full_force(mod, beads, fp, 0.1, {"mu": 3.0}, x, v)
    np.testing.assert_array_equal(force.force(x, v), ref)
    for lo, hi in ((0, 21), (10, 31), (150, 200)):
        np.testing.assert_array_equal(force.restrict(lo, hi).force(x[lo:hi], v[lo:hi]), ref[lo:hi])


def test_a_uniform_million_bead_chain_builds_no_array_over_beads():
    mod = force_module("-(u - mu*(1 - u^2)*v)", ("mu",))
    tracemalloc.start()
    force = chain_force(mod, {"beads": 1_000_000, "first_perturbed": 16, "eps": 0.1}, {"mu": 3.0})
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 1_000_000  # bytes; one float array over the beads alone is 8 MB
    small = chain_force(mod, {"beads": 200, "first_perturbed": 16, "eps": 0.1}, {"mu": 3.0})
    np.testing.assert_array_equal(force.monomials.coefficients, small.monomials.coefficients)
    assert force.monomials.coefficients.shape[1] == 16
    assert force.stiffness_hint == small.stiffness_hint


def test_site_dependent_values_span_the_chain():
    mod = force_module("-mu*v", ("mu",))
    mu = np.linspace(0.5, 1.5, 60)
    force = chain_force(mod, {"beads": 60, "first_perturbed": 16, "eps": 0.1}, {"mu": mu})
    assert force.monomials.coefficients.shape[1] == 60
    np.testing.assert_array_equal(force.monomials.coefficients[0, 15:], -0.1 * mu[15:])


def test_make_force_is_kept_for_the_same_resolved_scene():
    a = pulsemap.scene("fig8-eps0.1")
    b = pulsemap.scene("fig8-eps0.1")
    assert make_force(a, 131) is make_force(b, 131)
    assert make_force(pulsemap.scene("fig8-eps0.1", eps=0.2), 131) is not make_force(a, 131)


def test_one_random_draw_on_both_sides():
    pert = make_perturbation("-mu*v", 0.1, {"mu": {"uniform": [0.2, 0.9], "seed": 11}})
    worker = bead_params({"beads": 50, "params": {"mu": {"uniform": [0.2, 0.9], "seed": 11}}})["mu"]
    np.testing.assert_array_equal(pert.bead_values("mu", 50), worker)
    assert worker.min() >= 0.2 and worker.max() < 0.9 and np.unique(worker).size == 50


def test_every_dns_caller_builds_its_chain_through_the_one_builder():
    """No module above models/ assembles a force: none calls onsite_force or constructs a Chain with a force."""
    import re
    from pathlib import Path

    root = Path(pulsemap.__file__).resolve().parent / "solvers"
    for path in (root / "studies").rglob("*.py"):
        text = path.read_text(encoding="utf-8")
        assert "onsite_force" not in text, path
        assert not re.search(r"\bChain\(", text), f"{path} constructs a Chain: use studies/scene_chain.scene_chain"
