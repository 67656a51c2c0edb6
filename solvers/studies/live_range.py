"""The live range over which reduced models are scored against the DNS.

Contacts first_perturbed .. the last contact whose DNS peak is still >= LIVE_FRACTION of the
seed peak (the DNS peak at contact first_perturbed - 1, which seeds every model). Past it the
pulse has all but died: relative errors there measure noise on a vanishing peak, not the model.
"""

from __future__ import annotations

import math
from typing import Sequence

LIVE_FRACTION = 0.02


def live_contacts(contacts: Sequence[int], dns: Sequence[float | None], seed_contact: int, seed_peak: float,
                  fraction: float = LIVE_FRACTION) -> list[int]:
    """Contacts after ``seed_contact`` up to the last one whose DNS peak is >= fraction * seed_peak
    (only contacts with a live DNS peak; [] without a seed)."""
    if seed_peak is None or not (math.isfinite(seed_peak) and seed_peak > 0):
        return []
    alive = [(int(c), p) for c, p in zip(contacts, dns) if c > seed_contact and p is not None]
    strong = [c for c, p in alive if p >= fraction * seed_peak]
    if not strong:
        return []
    return [c for c, _ in alive if c <= strong[-1]]


def rms_on(contacts: Sequence[int], reference: Sequence[float | None], values: Sequence[float | None],
           live: Sequence[int]) -> dict:
    """RMS and max relative error of ``values`` against ``reference`` on the ``live`` contacts.

    ``missing``: live contacts without a model value (the model has ended there); ``rms_rel`` and
    ``max_rel`` leave them out, ``rms_rel_all`` and ``max_rel_all`` count them as predicting 0
    (relative error 1), for rankings. ``contacts``: [first, last] of the live range.
    """
    ref = dict(zip(contacts, reference))
    got = dict(zip(contacts, values))
    errs = [abs(got[c] - ref[c]) / ref[c] for c in live if got.get(c) is not None]
    missing = sum(got.get(c) is None for c in live)
    out = {"contacts": [live[0], live[-1]] if live else None, "compared": len(errs), "missing": missing,
           "rms_rel": None, "max_rel": None, "rms_rel_all": None, "max_rel_all": None}
    if errs:
        out["rms_rel"] = math.sqrt(sum(e * e for e in errs) / len(errs))
        out["max_rel"] = max(errs)
    if errs or missing:
        full = errs + [1.0] * missing
        out["rms_rel_all"] = math.sqrt(sum(e * e for e in full) / len(full))
        out["max_rel_all"] = max(full)
    return out
