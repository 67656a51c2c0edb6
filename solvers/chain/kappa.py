"""Impulse-to-soliton constant kappa_n of the unperturbed chain (paper Eq. 1 with eps = 0).

A chain at rest hit by v0 on bead 1 forms a solitary wave whose peak strain is
kappa_n * v0^(2/(n+1)) (homogeneity of Eq. 1: x -> lambda x, t -> lambda^(-(n-1)/2) t). kappa_n
is measured once per n by a DNS at v0 = 1 at a contact far enough down the chain that the wave
has formed (peaks at contact c-5..c+5 agree to 1e-6 relative; c = 30, doubled while they do
not, as near n = 1 the wave forms slowly), and cached on disk (pulsemap.symbolic.cache, namespace "kappa").
"""

from __future__ import annotations

import numpy as np

from pulsemap.symbolic import cache
from pulsemap.solvers.chain.errors import DNSInputError
from pulsemap.solvers.chain.dns import Chain, Integrator, chain_length_for, simulate
from pulsemap.solvers.chain.peaks import velocity_scale

NAMESPACE = "kappa"
FIRST_CONTACT = 30
MAX_CONTACT = 480
HALF_WINDOW = 5
FORMATION_TOL = 1e-6


def cache_key(exponent: float, rtol: float) -> str:
    """Cache key naming everything kappa_n depends on (n, tolerances, measurement contact)."""
    return (f"kappa|n={float(exponent)!r}|rtol={float(rtol)!r}|atol=1e-12|v0=1.0|method=DOP853"
            f"|contact={FIRST_CONTACT} doubled to {MAX_CONTACT} until peaks c+-{HALF_WINDOW}"
            f" agree to {FORMATION_TOL:g}|margin=10")


def formation_spread(peaks: np.ndarray, centre_index: int) -> float:
    """max |p_k / p_c - 1| over the window around the measurement contact."""
    window = peaks[centre_index - HALF_WINDOW : centre_index + HALF_WINDOW + 1]
    return float(np.max(np.abs(window / peaks[centre_index] - 1.0)))


def measure_kappa(exponent: float, *, rtol: float = 1e-10) -> dict:
    """DNS measurement of kappa_n at v0 = 1 (no cache). Returns value, contact, beads, spread."""
    tol = max(FORMATION_TOL, 100.0 * rtol)
    contact = FIRST_CONTACT
    while True:
        lo, hi = contact - HALF_WINDOW, contact + HALF_WINDOW
        beads = chain_length_for(hi)
        res = simulate(Chain(beads, exponent, 1.0), (lo, hi),
                       integrator=Integrator(method="DOP853", rtol=rtol, atol=1e-12, engine="scipy"))
        if not np.all(res.alive):
            raise RuntimeError(f"kappa(n={exponent}): unperturbed DNS ended early: {res.stop_reason}")
        spread = formation_spread(res.peaks, HALF_WINDOW)
        if spread <= tol:
            return {"kappa": float(res.peaks[HALF_WINDOW]), "contact": contact, "beads": beads,
                    "spread": spread, "rtol": float(rtol)}
        if 2 * contact > MAX_CONTACT:
            raise RuntimeError(
                f"kappa(n={exponent}): the solitary wave has not formed by contact {contact} "
                f"(peaks vary by {spread:.2g} > {tol:g}); n is too close to 1 for this measurement"
            )
        contact *= 2


def _check_entry(entry: object) -> str | None:
    """What is wrong with a cached kappa entry, or None: kappa must be a finite number > 0."""
    if not isinstance(entry, dict):
        return f"a {type(entry).__name__}, not a kappa entry"
    value = entry.get("kappa")
    if not cache.finite_number(value) or value <= 0:
        return f"kappa = {value!r}, not a finite number > 0"
    return None


def kappa(exponent: float, *, rtol: float = 1e-10) -> float:
    """kappa_n: formed solitary-wave peak per v0^(2/(n+1)) (cached DNS measurement)."""
    if not np.isfinite(exponent) or exponent <= 1.0:
        raise DNSInputError(f"exponent must be a finite number > 1, got {exponent!r}")
    if not (np.isfinite(rtol) and 0.0 < rtol < 1e-4):
        raise DNSInputError(f"rtol must lie in (0, 1e-4) for a meaningful kappa, got {rtol!r}")
    key = cache_key(exponent, rtol)
    hit = cache.load(NAMESPACE, key, check=_check_entry)
    if hit is not None:
        return float(hit["kappa"])
    entry = measure_kappa(exponent, rtol=rtol)
    cache.store(NAMESPACE, key, entry)
    return entry["kappa"]


def peak_from_velocity(v0: float, exponent: float) -> float:
    """Formed solitary-wave peak strain for impact velocity v0: kappa_n v0^(2/(n+1))."""
    if not (np.isfinite(v0) and v0 > 0.0):
        raise DNSInputError(f"v0 must be a finite number > 0, got {v0!r}")
    return kappa(exponent) * velocity_scale(v0, exponent)


def velocity_from_peak(peak: float, exponent: float) -> float:
    """Impact velocity whose formed solitary wave has this peak: (peak/kappa_n)^((n+1)/2)."""
    if not (np.isfinite(peak) and peak > 0.0):
        raise DNSInputError(f"peak must be a finite number > 0, got {peak!r}")
    return (peak / kappa(exponent)) ** ((exponent + 1.0) / 2.0)
