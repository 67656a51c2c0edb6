"""k2/k1 and the onset lag of one monomial, derived from the expansion about the solitary wave.

dressed_expansion.py integrates the first- and second-order equations of Eq. 1 expanded in c about the
exact wave and returns, per step k, k1_k, rho_k = k2_k/k1_k (A at the step's mid-point) and the lag
Delta_k. Two limits remain, each taken here with its error stated:

* the cut of F'' (the one-sided contact's tails): rho is computed for the cuts CUTS (ratio 10) and
  extrapolated geometrically, rho = rho_3 + d_2 q/(1 - q), d_j = rho_j - rho_(j+1), q = d_2/d_1
  (v, u^2 v: q = 0.10, i.e. linear in the cut; foundations: q ~ 0.4); error: |d_2 q/(1 - q)|;
* the chain: rho_k and Delta_k relax geometrically along the chain (ratio ~0.56 per contact for v);
  the last value is extrapolated the same way over the last three steps; error: the extrapolation
  plus the last increment.

k1 is recomputed in the time domain and must equal the energy balance's -w_ab/((n + 1) E_1); its
deviation is reported (``k1_check``). The lag is a first-order quantity (no F'', no cut). Results are
cached on disk (namespace "dressed-derived"); the paper's monomials ship precomputed in
solvers/data/dressed_derived.json (``write_shipped``).
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from pulsemap.symbolic import cache
from pulsemap.symbolic.scaling import scaling_exponent
from pulsemap.solvers.models.dressed_expansion import (chain_coefficients, chain_cross, check_monomial,
                                                       first_order_rate)

NAMESPACE = "dressed-derived"
SHIPPED = Path(__file__).resolve().parents[1] / "data" / "dressed_derived.json"
METHOD_VERSION = 1
CUTS = (1e-7, 1e-8, 1e-9)
SETTLE, SPAN, RTOL = 12, 24, 1e-10


@dataclass(frozen=True)
class DerivedMonomial:
    """The derived second-order coefficients of c u^a v^b (module docstring)."""

    a: int
    b: int
    n: float
    e: float
    k1: float  # from the time-domain first order (equals the energy balance: k1_check)
    k2_over_k1: float
    k2_over_k1_error: float
    cut_extrapolation: float  # the part of k2/k1 added by the cut -> 0 extrapolation
    onset_lag: float
    onset_lag_error: float
    per_cut: tuple[float, ...]  # k2/k1 at the last step for each cut of CUTS
    method: str

    def as_dict(self) -> dict:
        return asdict(self)

    def label(self, what: str) -> str:
        """The provenance label: "derived (method, accuracy)"."""
        if what == "rho":
            return (f"derived (O(c^2) expansion about the exact wave, cut -> 0; accuracy +-{self.k2_over_k1_error:.2g})")
        return f"derived (O(c) half-chain problem about the exact wave; accuracy +-{self.onset_lag_error:.2g})"


def geometric_limit(values: np.ndarray) -> tuple[float, float]:
    """The limit of a geometrically converging sequence from its last three terms, and its error
    (the extrapolated tail; plus the last increment when the sequence is not geometric)."""
    v = np.asarray(values, dtype=float)
    d1, d2 = v[-2] - v[-3], v[-1] - v[-2]
    if d1 != 0 and 0 < d2 / d1 < 0.9:
        q = d2 / d1
        tail = d2 * q / (1 - q)
        return float(v[-1] + tail), float(abs(tail))
    return float(v[-1]), float(abs(d2) + abs(d1))


def _cuts(n: float) -> tuple[float, ...]:
    """The cut ladder: F'' is bounded for n >= 2, one run (no cut) is the limit."""
    return CUTS if n < 2 else (0.0,)


def _cut_limits(values: np.ndarray) -> list[tuple[float, float]]:
    """Per step (columns) the cut -> 0 limit of values (rows: the cuts of _cuts) and its error."""
    if values.shape[0] == 1:
        return [(float(v), 0.0) for v in values[0]]
    return [geometric_limit(values[:, k]) for k in range(values.shape[1])]


def _cut_text(n: float) -> str:
    return ("F'' bounded (n >= 2): no cut" if n >= 2 else
            f"F'' cut -> 0 from cuts {', '.join(f'{c:g}' for c in CUTS)}")


def cache_key(a: int, b: int, n: float) -> str:
    return f"derived-v{METHOD_VERSION}|n={float(n)!r}|a={int(a)}|b={int(b)}|cuts={CUTS}|settle={SETTLE}|span={SPAN}|rtol={RTOL}"


@lru_cache(maxsize=1)
def shipped() -> dict:
    """Derived coefficients shipped with pulsemap (SHIPPED), by cache key."""
    try:
        return json.loads(SHIPPED.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}


def derive_monomial(a: int, b: int, n: float = 1.5, use_cache: bool = True) -> DerivedMonomial:
    """k2/k1 and the onset lag of c u^a v^b at exponent n from the expansion (module docstring); cached."""
    (a, b), n = check_monomial(a, b), float(n)
    key = cache_key(a, b, n)
    if use_cache:
        hit = cache.load(NAMESPACE, key) or shipped().get(key)
        if hit is not None:
            hit = dict(hit)
            hit["per_cut"] = tuple(hit["per_cut"])
            return DerivedMonomial(**hit)
    runs = [chain_coefficients(a, b, n, cut=cut, settle=SETTLE, span=SPAN, rtol=RTOL) for cut in _cuts(n)]
    rho = np.array([r["rho"] for r in runs])  # (cut, step)
    limits = _cut_limits(rho)
    along = np.array([v for v, _ in limits])
    value, chain_err = geometric_limit(along)
    cut_err = limits[-1][1]
    lag, lag_err = geometric_limit(runs[-1]["lag"])
    k1 = float(runs[-1]["k1"][-1])
    # the integration's accuracy: k1 against the energy balance, accumulated over the contacts used
    spread = float(np.ptp([r["k1"][-1] for r in runs]) + abs(k1 / first_order_rate(a, b, n) - 1) * (SETTLE + SPAN))
    out = DerivedMonomial(
        a=a, b=b, n=n, e=float(scaling_exponent(a, b, n)), k1=k1,
        k2_over_k1=value, k2_over_k1_error=float(cut_err + chain_err + spread),
        cut_extrapolation=float(along[-1] - rho[-1, -1]),
        onset_lag=lag, onset_lag_error=float(lag_err + spread), per_cut=tuple(float(v) for v in rho[:, -1]),
        method=(f"derived: Eq. 1 expanded to O(c^2) about the exact wave (DOP853, rtol {RTOL:g}), decrements of "
                f"steps first+{SETTLE}..first+{SETTLE + SPAN} extrapolated along the chain; {_cut_text(n)}"),
    )
    cache.store(NAMESPACE, key, out.as_dict())
    return out


@dataclass(frozen=True)
class DerivedCross:
    """The derived cross coefficient k2_jl of a pair of monomials (chain_cross, same limits as k2/k1)."""

    first: tuple[int, int]
    second: tuple[int, int]
    n: float
    k2: float
    error: float
    per_cut: tuple[float, ...]
    method: str

    def as_dict(self) -> dict:
        return asdict(self)


def cross_key(first, second, n: float) -> str:
    return f"cross|{cache_key(*first, n)}|{cache_key(*second, n)}"


def derive_cross(first: tuple[int, int], second: tuple[int, int], n: float = 1.5, use_cache: bool = True) -> DerivedCross:
    """k2_jl of c_j u^a v^b + c_l u^a' v^b' from the mixed second order of the expansion; cached."""
    first, second, n = check_monomial(*first), check_monomial(*second), float(n)
    key = cross_key(first, second, n)
    if use_cache:  # k2_jl is symmetric: either order's entry serves
        swapped = cross_key(second, first, n)
        hit = (cache.load(NAMESPACE, key) or shipped().get(key) or cache.load(NAMESPACE, swapped)
               or shipped().get(swapped))
        if hit is not None:
            hit = dict(hit)
            for name in ("first", "second", "per_cut"):
                hit[name] = tuple(hit[name])
            hit["first"], hit["second"] = first, second
            return DerivedCross(**hit)
    runs = [chain_cross(first, second, n, cut=cut, settle=SETTLE, span=SPAN, rtol=RTOL) for cut in _cuts(n)]
    k2 = np.array([r["k2"] for r in runs])
    limits = _cut_limits(k2)
    value, chain_err = geometric_limit(np.array([v for v, _ in limits]))
    out = DerivedCross(first, second, n, value, float(limits[-1][1] + chain_err), tuple(float(v) for v in k2[:, -1]),
                       f"derived: mixed O(c_j c_l) term of the expansion about the exact wave; {_cut_text(n)}")
    cache.store(NAMESPACE, key, out.as_dict())
    return out


def write_shipped(monomials=((1, 0), (3, 0), (0, 1), (2, 1)), pairs=(((1, 0), (0, 1)), ((1, 0), (2, 1)), ((0, 1), (2, 1))),
                  n: float = 1.5) -> Path:
    """Recompute (no cache) the derived coefficients of the paper's monomials and pairs and write SHIPPED."""
    table = {cache_key(a, b, n): derive_monomial(a, b, n, use_cache=False).as_dict() for a, b in monomials}
    for p, q in pairs:
        table[cross_key(p, q, n)] = derive_cross(p, q, n, use_cache=False).as_dict()
    SHIPPED.write_text(json.dumps(table, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    shipped.cache_clear()
    return SHIPPED
