"""The error of a reduced model against the DNS: one definition, used by every output.

A model's error is its relative peak error |model - DNS| / DNS in percent over the *live range*:
contacts first_perturbed .. the last contact whose DNS peak is still >= LIVE_FRACTION of the seed
peak (the DNS peak at contact first_perturbed - 1, which seeds every model). Past it the pulse has
all but died and relative errors measure noise on a vanishing peak, not the model. A live contact
where the model has no value (it has ended: died, blown up) counts as a relative error of 100 %.
``run`` (text, JSON ``errors``, ``Result.errors``), ``--rank``, ``table``, ``sweep`` and ``bench``
all call :func:`model_error`.
"""

from __future__ import annotations

import math
from typing import Sequence

__all__ = ["LIVE_FRACTION", "UNIT", "counted", "live_contacts", "model_error"]

LIVE_FRACTION = 0.02  # below 2 % of the seed the pulse has all but died: a relative error there measures noise
UNIT = "percent"
#: What an error means, in one line (text reports and docs).
DEFINITION = (f"|model peak - DNS peak| / DNS peak in percent over the live range (contacts first_perturbed up to "
              f"the last whose DNS peak is >= {100 * LIVE_FRACTION:g} % of the seed peak); a live contact where the "
              "model has no value counts 100 %")


def counted(count: int, noun: str) -> str:
    """'1 contact', '3 contacts': a count with its noun, plural unless one (every report's wording)."""
    return f"{count} {noun}" + ("" if count == 1 else "s")


def live_contacts(contacts: Sequence[int], dns: Sequence[float | None], seed_contact: int,
                  seed_peak: float | None, fraction: float = LIVE_FRACTION) -> list[int]:
    """Contacts after ``seed_contact`` up to the last one whose DNS peak is >= fraction * seed_peak
    (only contacts with a live DNS peak; [] without a seed)."""
    if seed_peak is None or not (math.isfinite(seed_peak) and seed_peak > 0):
        return []
    alive = [(int(c), p) for c, p in zip(contacts, dns) if c > seed_contact and p is not None]
    strong = [c for c, p in alive if p >= fraction * seed_peak]
    if not strong:
        return []
    return [c for c, _ in alive if c <= strong[-1]]


def model_error(contacts: Sequence[int], dns: Sequence[float | None], values: Sequence[float | None],
                seed_contact: int, seed_peak: float | None) -> dict:
    """The error of ``values`` against the DNS peaks ``dns`` (both per contact of ``contacts``).

    ``{"unit": "percent", "rms_pct", "max_pct", "live_range": [first, last] or None, "compared":
    live contacts with a model value, "missing": live contacts without one (each counted 100 %)}``;
    rms_pct and max_pct are None when the live range is empty.
    """
    live = live_contacts(contacts, dns, seed_contact, seed_peak)
    ref = dict(zip((int(c) for c in contacts), dns))
    got = dict(zip((int(c) for c in contacts), values))
    rel = [abs(got[c] - ref[c]) / ref[c] for c in live if got.get(c) is not None]
    missing = len(live) - len(rel)
    full = rel + [1.0] * missing
    out: dict = {"unit": UNIT, "rms_pct": None, "max_pct": None, "live_range": [live[0], live[-1]] if live else None,
                 "compared": len(rel), "missing": missing}
    if full:
        out["rms_pct"] = 100.0 * math.sqrt(sum(e * e for e in full) / len(full))
        out["max_pct"] = 100.0 * max(full)
    return out
