"""Public functions called with wrong types: a TypeError or ValueError naming the argument,
raised before any work -- never an AttributeError or MemoryError from deep inside."""

from __future__ import annotations

import pytest

import pulsemap
from pulsemap.solvers.chain import dns
from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.chain.errors import DNSInputError
from pulsemap.solvers.chain.peaks import StopRules
from pulsemap.solvers.data.scene import schema as scene_schema
from pulsemap.solvers.data.scene import load_scene, parse_scene


@pytest.fixture(scope="module")
def scene():
    return load_scene("fig8-eps0.1")


OK = dict(beads=40, exponent=1.5, velocity=1.0, contacts=(16, 30))

SIMULATE = [
    ("beads", {"beads": "40"}, TypeError),
    ("beads", {"beads": 40.0}, ValueError),
    ("beads", {"beads": 10 ** 12}, ValueError),
    ("exponent", {"exponent": "1.5"}, TypeError),
    ("velocity", {"velocity": [1.0]}, TypeError),
    ("velocity", {"velocity": None}, TypeError),
    ("contacts", {"contacts": "16,30"}, ValueError),
    ("force", {"force": "-mu*v"}, TypeError),
    ("rtol", {"rtol": "1e-8"}, TypeError),
    ("atol", {"atol": True}, TypeError),
    ("method", {"method": 3}, TypeError),
    ("t_max", {"stop": lambda: StopRules(t_max="10")}, TypeError),  # refused when made
    ("stop", {"stop": {"t_max": 10.0}}, TypeError),
    ("progress", {"progress": "yes"}, TypeError),
    ("max_steps", {"stop": lambda: StopRules(max_steps=1.5)}, ValueError),
]


@pytest.mark.parametrize("name, bad, error", SIMULATE, ids=[f"{c[0]}=" + (f"{v!r}" if not callable(v) else "made-bad")[:40]
                                                          for c in SIMULATE for v in [list(c[1].values())[0]]])
def test_simulate_names_the_bad_argument(name, bad, error):
    kw = {**OK, **bad}
    with pytest.raises(error) as info:
        if callable(kw.get("stop")):
            kw["stop"] = kw["stop"]()
        chain = Chain(kw.pop("beads"), kw.pop("exponent"), kw.pop("velocity"), kw.pop("force", None))
        integrator = Integrator(**{k: kw.pop(k) for k in ("method", "rtol", "atol", "engine") if k in kw})
        simulate(chain, kw.pop("contacts"), integrator=integrator, **kw)
    assert type(info.value) in (TypeError, DNSInputError) and str(info.value).startswith(name)
    assert "\n" not in str(info.value)


def test_the_chain_limit_is_the_scene_limit():
    assert dns.MAX_BEADS == scene_schema.MAX_BEADS


RUN = [
    ("scene", lambda s: pulsemap.run([s]), TypeError),
    ("methods", lambda s: pulsemap.run(s, methods=("map", 3)), TypeError),
    ("profile", lambda s: pulsemap.run(s, profile=3), TypeError),
    ("variant", lambda s: pulsemap.run(s, variant=["1d"]), TypeError),
    ("progress", lambda s: pulsemap.run(s, progress=None), TypeError),
    ("ref", lambda s: load_scene(["fig8-eps0.1"]), TypeError),
    ("ref", lambda s: load_scene(None), TypeError),
    ("source", lambda s: parse_scene(s.as_dict(), None), TypeError),
    ("name", lambda s: __import__("pulsemap.solvers.data.scene", fromlist=["x"]).builtin_scene_path(3), TypeError),
]


@pytest.mark.parametrize("name, call, error", RUN, ids=[f"{c[0]}-{i}" for i, c in enumerate(RUN)])
def test_run_and_scene_functions_name_the_bad_argument(name, call, error, scene):
    with pytest.raises(error) as info:
        call(scene)
    assert str(info.value).startswith(name) and "\n" not in str(info.value)
