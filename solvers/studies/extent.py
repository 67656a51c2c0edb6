"""What a run's DNS covers and how it is integrated, read from the scene: one place for every run, sweep task and
bench line.

:func:`dns_span` (the chain's length and the contacts tracked), :func:`dns_window_of` (the full chain or the moving
window, by the scene's [dns] mode), :func:`dns_integrator` (the Integrator of a scene's [dns] table or of a sweep
point's copy of it, with the schema's defaults) and :func:`on_contacts` (values put on the reported contacts).
"""

from __future__ import annotations

import itertools
import math
from typing import Any, Mapping, Sequence

from pulsemap.solvers.chain.dns import Integrator, chain_length_for
from pulsemap.solvers.data.scene.schema import DNS_DEFAULTS

__all__ = ["dns_integrator", "dns_span", "dns_window_of", "on_contacts"]


def dns_span(scene) -> tuple[int, tuple[int, int]]:
    """(beads, (first, last)) of a scene's DNS: the scene's chain length, else chain_length_for(last),
    and the contacts it tracks, from the map's seed contact first_perturbed - 1 (or the first
    reported contact, if earlier) to the last reported one."""
    c0, c1 = scene.contacts
    return scene.beads or chain_length_for(c1), (min(c0, scene.first_perturbed - 1), c1)


def dns_window_of(scene, dns_window: "int | str | None") -> "int | str | None":
    """The window a run's DNS uses: ``dns_window`` as given ("scene": the scene's [dns] mode, "window"
    (the moving window sized by its accuracy rule, "auto") unless it says "full"; None: the full chain)."""
    if dns_window == "scene":
        return None if scene.dns.get("mode", "window") == "full" else "auto"
    return dns_window


def dns_integrator(dns: Mapping[str, Any]) -> Integrator:
    """The Integrator of a scene's [dns] table (or a sweep point's copy of it): method, tolerances and engine,
    each absent key at the scene schema's default (the compiled engine where it applies)."""
    return Integrator(method=str(dns.get("method", DNS_DEFAULTS["method"])),
                      rtol=float(dns.get("rtol", DNS_DEFAULTS["rtol"])), atol=float(dns.get("atol", DNS_DEFAULTS["atol"])),
                      engine=str(dns.get("engine", "compiled")))


def on_contacts(contacts: Sequence[int], at: Sequence[int], values: Sequence[float | None],
                alive: Sequence[bool] | None = None) -> list[float | None]:
    """``values`` given at contacts ``at`` (a DNS, a baseline or a model run) on ``contacts``:
    None where there is no value, it is not finite, or ``alive`` (a DNS's live flags) is False."""
    flags = itertools.repeat(True) if alive is None else alive
    got = {int(c): float(v) for c, v, a in zip(at, values, flags) if a and v is not None and math.isfinite(v)}
    return [got.get(int(c)) for c in contacts]
