"""A chain as plain parameters, and the sweep tasks that run it (DNS of Eq. 1, map of Eq. 23); its chain is
built by :func:`~pulsemap.solvers.models.chain_build.build_chain`, as every DNS's.

The parent turns a Scene (whose perturbation is a sympy object) into a plain dict with
:func:`plain_chain`: numbers, per-bead lists, random draws as ``{"uniform": [lo, hi], "seed": s}``
and the name + source hash of the generated force and map modules (generated here, in the
parent). The tasks :func:`dns_task` and :func:`dns_map_task` run in workers from that dict alone:
they load the generated modules by name, check their hash, and never import sympy.
"""

from __future__ import annotations

from typing import Any, Mapping


from pulsemap.symbolic.param_forms import RandomDraw
from pulsemap.solvers.chain.dns import simulate
from pulsemap.solvers.models.chain_build import ChainSpec, build_chain, plain_values
from pulsemap.solvers.studies.extent import dns_integrator, dns_span, dns_window_of, on_contacts
from pulsemap.solvers.studies.sweep import SweepError, generated_ref, load_generated

__all__ = ["bead_params", "dns_map_task", "dns_task", "plain_chain", "random_params"]


# ----------------------------------------------------------------------------- parent side


def _param_data(pert, name: str, beads: int) -> Any:
    value = pert.params[name]
    if name not in pert.site_dependent:
        return float(value)
    if isinstance(value, RandomDraw):
        return {value.distribution: [float(value.low), float(value.high)], "seed": int(value.seed)}
    return [float(x) for x in pert.bead_values(name, beads)]


def random_params(scene) -> list[str]:
    """Names of the scene's parameters drawn at random per bead (sorted)."""
    pert = scene.perturbation
    return sorted(n for n in pert.used_parameters if isinstance(pert.params[n], RandomDraw))


def plain_chain(scene, *, with_map: bool = False, profile: str | None = None, variant: str | None = None,
                window: "int | str | None" = "scene", rtol: float | None = None, study: str = "sweep tasks") -> dict:
    """The scene as the plain dict the tasks take; generates the modules it needs (parent only).

    Contacts: the DNS tracks first_perturbed - 1 (the map's seed contact) through the scene's
    last contact. ``window``: "scene" (the scene's [dns] mode, as ``pulsemap run``), None (whole
    chain), "auto" or a width. ``study``: who asks (refused where a kind the scene states does not take it:
    studies/run/kinds.py).
    """
    from pulsemap.solvers.models.codeload import force_module, map_module
    from pulsemap.solvers.studies.run.kinds import require

    require(scene, study)
    pert = scene.perturbation
    beads, (first, last) = dns_span(scene)
    out = {
        "exponent": float(scene.exponent),
        "first_perturbed": int(scene.first_perturbed),
        "velocity": float(scene.velocity),
        "eps": float(pert.eps),
        "beads": int(beads),
        "contacts": [int(first), int(last)],
        "params": {name: _param_data(pert, name, beads) for name in pert.used_parameters},
        "dns": {"rtol": float(rtol if rtol is not None else scene.dns["rtol"]), "atol": float(scene.dns["atol"]),
                "method": str(scene.dns["method"]), "window": dns_window_of(scene, window),
                **({"engine": str(scene.dns["engine"])} if "engine" in scene.dns else {})},
        "force": generated_ref(force_module(pert.text, pert.used_parameters)),
    }
    if with_map:
        mod = map_module(pert.text, pert.used_parameters, scene.exponent, profile or scene.profile,
                         variant or scene.variant, pert.site_dependent)
        out["map"] = generated_ref(mod)
    return out


# ----------------------------------------------------------------------------- worker side


def bead_params(chain: Mapping[str, Any]) -> dict:
    """Parameter values of a plain chain: floats, or per-bead arrays (chain_build.plain_values)."""
    return plain_values(chain["params"], int(chain["beads"]))


def _dns(chain: Mapping[str, Any], values: Mapping[str, Any]) -> dict:
    module = load_generated(chain["force"])
    spec = ChainSpec(int(chain["beads"]), float(chain["exponent"]), float(chain["velocity"]), module.SOURCE["R"],
                     tuple(module.PARAMS), values, float(chain["eps"]), int(chain["first_perturbed"]))
    opts = chain["dns"]
    first, last = (int(c) for c in chain["contacts"])
    res = simulate(build_chain(spec, module), (first, last), integrator=dns_integrator(opts), window=opts.get("window"))
    contacts = list(range(first, last + 1))
    peaks = on_contacts(contacts, res.contacts, res.peaks, res.alive)
    live = [c for c, p in zip(contacts, peaks) if p is not None]
    return {
        "contacts": contacts,
        "peaks": peaks,
        "alive_to": live[-1] if live else None,
        "stop_reason": res.stop_reason,
        "method": res.method,
        "nfev": int(res.nfev),
        "mode": res.mode,
    }


def dns_task(chain: Mapping[str, Any]) -> dict:
    """Sweep task: the DNS of the plain chain; leading-edge peaks per contact (None: no live pulse)."""
    return _dns(chain, bead_params(chain))


def dns_map_task(chain: Mapping[str, Any]) -> dict:
    """Sweep task: the DNS, and the map (Eq. 23) seeded from the DNS peak at contact
    first_perturbed - 1 (Eq. 32), over the same contacts, with the relative error per contact."""
    from pulsemap.solvers.models.map_iteration import iterate_map

    if "map" not in chain:
        raise SweepError("dns_map_task needs a 'map' module reference: plain_chain(scene, with_map=True)")
    values = bead_params(chain)
    out = _dns(chain, values)
    seed_contact = int(chain["first_perturbed"]) - 1
    contacts = out["contacts"]
    seed_peak = out["peaks"][contacts.index(seed_contact)] if seed_contact in contacts else None
    out["seed_peak"] = seed_peak
    if seed_peak is None:
        raise SweepError(f"the DNS has no live pulse at the seed contact {seed_contact}: nothing to seed the map with")
    mod = load_generated(chain["map"])
    run = iterate_map(mod, seed_peak / float(mod.S0), seed_contact, contacts[-1], float(chain["eps"]), values)
    out["map_peaks"] = on_contacts(contacts, run.contacts, run.peaks)
    out["map_status"] = run.status
    out["map_variant"] = run.variant
    out["map_profile"] = run.profile
    out["rel_error"] = [
        None if (d is None or m is None or c <= seed_contact) else abs(m - d) / abs(d)
        for c, d, m in zip(contacts, out["peaks"], out["map_peaks"])
    ]
    return out
