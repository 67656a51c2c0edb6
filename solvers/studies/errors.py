"""Errors of the reduced models against the DNS peaks: max and RMS relative error per model."""

from __future__ import annotations

import numpy as np

__all__ = ["STRONG_FRACTION", "errors_vs_dns"]

STRONG_FRACTION = 0.1  # "strong" contacts: DNS peak at least this fraction of the seed peak


def errors_vs_dns(ref: list, alive: list, values: list, seed_peak: float | None = None) -> dict:
    """Max and RMS relative error of ``values`` against the live DNS peaks.

    ``max_rel_strong``: the max over contacts whose DNS peak is at least STRONG_FRACTION of the
    seed peak (near extinction relative errors of any model approach 100 %).
    """
    out = _rel_errors(ref, alive, values)
    if seed_peak is not None:
        strong = [a and r is not None and r >= STRONG_FRACTION * seed_peak for r, a in zip(ref, alive)]
        strong_errors = _rel_errors(ref, strong, values)
        out["max_rel_strong"] = strong_errors["max_rel"]
        out["max_rel_strong_all"] = strong_errors.get("max_rel_all")
    return out


def _rel_errors(ref: list, alive: list, values: list) -> dict:
    """Max/RMS relative error where the model has a value; ``*_all``: over every live contact, a
    model that has ended (no value) counting as predicting 0 (relative error 1), for rankings."""
    rel = []
    missing = 0
    for r, a, v in zip(ref, alive, values):
        if not a or r is None:
            continue
        if v is None:
            missing += 1
            continue
        rel.append(abs(v - r) / abs(r))
    if not rel:
        out = {"max_rel": None, "rms_rel": None, "compared": 0, "missing": missing}
        out.update(max_rel_all=1.0 if missing else None, rms_rel_all=1.0 if missing else None)
        return out
    arr = np.array(rel)
    full = np.concatenate([arr, np.ones(missing)])
    return {"max_rel": float(arr.max()), "rms_rel": float(np.sqrt(np.mean(arr**2))), "compared": int(arr.size),
            "missing": missing, "max_rel_all": float(full.max()), "rms_rel_all": float(np.sqrt(np.mean(full**2)))}
