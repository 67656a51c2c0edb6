"""What a run's DNS covers and how it is integrated, read from the scene: one place for every run, sweep task and
bench line.

:func:`dns_span` (the chain's length and the contacts tracked), :func:`dns_window_of` (the full chain or the moving
window, by the scene's [dns] mode), :func:`dns_integrator` (the Integrator of a scene's [dns] table or of a sweep
point's copy of it, with the schema's defaults) and :func:`on_contacts` (values put on the reported contacts).
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from pulsemap.solvers.chain.dns import Integrator, chain_length_for
from pulsemap.solvers.data.scene.schema import DNS_DEFAULTS

__all__ = ["contact_slots", "dns_integrator", "dns_span", "dns_window_of", "listed", "on_contacts"]


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
                      rtol=float(dns.get("rtol", DNS_DEFAULTS["rtol"])),
                      atol=float(dns.get("atol", DNS_DEFAULTS["atol"])), engine=str(dns.get("engine", "compiled")))


def on_contacts(contacts: Sequence[int], at: Sequence[int], values: Sequence[float | None],
                alive: Sequence[bool] | None = None) -> list[float | None]:
    """``values`` given at contacts ``at`` (a DNS, a baseline or a model run) on ``contacts``:
    None where there is no value, it is not finite, or ``alive`` (a DNS's live flags) is False; a
    contact given twice takes its last such value."""
    n = min(len(at), len(values), len(alive) if alive is not None else len(at))
    vals = np.asarray(values, dtype=float)[:n]  # None -> NaN
    valid = np.isfinite(vals) if alive is None else np.isfinite(vals) & np.asarray(alive, dtype=bool)[:n]
    found, index = contact_slots(contacts, np.asarray(at)[:n][valid])
    return listed(vals[valid], found, index)


def contact_slots(contacts: Sequence[int], at: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """(found, index): whether each of ``contacts`` occurs in ``at`` and where (its last occurrence; 0
    where absent), contacts compared as integers (``int(c)``); arrays in, no per-contact dict."""
    have = np.asarray(at).astype(np.int64).reshape(-1)
    want = np.asarray(contacts).astype(np.int64).reshape(-1)
    order = np.argsort(have, kind="stable")  # equal contacts keep their order: the last one is found
    ranked = have[order]
    pos = np.searchsorted(ranked, want, side="right") - 1
    found = pos >= 0
    found[found] = ranked[pos[found]] == want[found]
    index = np.zeros(want.size, dtype=np.intp)
    index[found] = order[pos[found]]
    return found, index


def listed(values: np.ndarray, keep: np.ndarray, index: np.ndarray) -> list[float | None]:
    """[values[index[k]] where keep[k], else None] as Python floats."""
    out: list[float | None] = (values[index] if values.size else np.zeros(index.size)).tolist()
    for k in np.flatnonzero(~keep).tolist():
        out[k] = None
    return out
