"""The dressed (second-order) law's expansion about the solitary wave and the coefficients derived from it.

derive/dressed.py holds the law symbolically and models/dressed.py evaluates it; this module computes its numbers,
in two parts:

1. The expansion (``expansion_orbits``, ``chain_coefficients``, ``chain_cross``): Eq. 1 expanded to O(c^2)
   about the exact solitary wave (profile of Eq. 4), integrated in time; per step k: k1_k, k2_k/k1_k, the lag.
2. The derived coefficients (``derive_monomial``, ``derive_cross``): part 1's values with the limits cut -> 0
   and along the chain taken, errors stated, cached on disk (namespace "dressed-derived") and shipped.

Part 1, the expansion. The dressed coefficients derived by expanding the chain about the exact solitary wave.

Eq. 1 with eps R = c u^a v^b on beads i >= ``first`` is expanded in c about the exact travelling wave
x0 (profile of Eq. 4, scale A = 1, contact ``centre`` at its peak at t = 0; derive/profile.py):
x = x0 + c y + c^2 z. With F(d) = d_+^n, strains d0 = x0_i - x0_{i+1}, eta = y_i - y_{i+1},
zeta = z_i - z_{i+1} and m_i the mask of the perturbed beads:

    y_i'' = F'(d0_{i-1}) eta_{i-1} - F'(d0_i) eta_i + m_i x0_i^a v0_i^b                             (first order)
    z_i'' = F'(d0_{i-1}) zeta_{i-1} - F'(d0_i) zeta_i + [F''(d0_{i-1}) eta_{i-1}^2 - F''(d0_i) eta_i^2]/2
            + m_i (a x0_i^(a-1) v0_i^b y_i + b x0_i^a v0_i^(b-1) y_i')                               (second order)

x0 is the profile itself (no integration: d0_j(t) = S(t + centre - j), the contacts' shared offset
on the profile grid makes one quintic Hermite weight vector serve them all; ``WaveBase``); y and z are
integrated with DOP853 from rest. These are the multiple-scales equations in the time domain (L S1 = ...
at first order, its solvability being the energy balance; the O(x^2) problem at second order): no
DNS of the nonlinear chain, no fit, no extrapolation in c. The peak of contact k (at t_k = k - centre)
to O(c^2), with the peak-time shift, is

    P_k = S0 + c eta_k + c^2 (zeta_k - eta_k'^2 / (2 S''(0))),   ln P_k = ln S0 + c alpha_k + c^2 beta_k,

and the decrement of step k at its mid-point x (x = c A^e, A = sqrt(A_k A_{k+1})) is
d_k = k1 x + k2 x^2 + O(x^3) with

    k1 = -(alpha_{k+1} - alpha_k),   k2 = -(beta_{k+1} - beta_k) - k1 e (alpha_k + alpha_{k+1})/2,

constant along the chain once the onset has relaxed (the spread over the contacts used is part of the
stated accuracy). The onset lag at c -> 0 (the half-chain problem: the perturbation starts at bead
``first``; a run seeds its models at contact first - 1):

    Delta = (i - i0) + (alpha_i - alpha_i0)/k1,   i0 = first - 1,   i past the onset.

The one-sided contact: F''(d0) = n (n - 1) d0^(n-2) is unbounded where d0 -> 0 (the tails, where the
expansion in c is not uniform: c eta exceeds d0 and the contact opens). It is tapered below a cut,
F'' -> n (n - 1) d0^n / (d0 + cut S0)^2 (n < 2; for n >= 2 F'' is bounded and kept whole), and the coefficients are computed on a ladder of cuts and
extrapolated geometrically to cut -> 0 (part 2; v converges like the cut itself, a
foundation, whose displaced wake opens its contacts, more slowly: its next term is not analytic,
|x|^(3/2)).

Part 2, the derived coefficients. k2/k1 and the onset lag of one monomial, derived from the expansion about the solitary wave.

Part 1 integrates the first- and second-order equations of Eq. 1 expanded in c about the
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
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.symbolic import cache
from pulsemap.symbolic.profile import NPU, exact_profile
from pulsemap.symbolic.scaling import scaling_exponent

# ----------------------------------------------------------------------- part 1: the expansion
class ExpansionError(PulsemapError):
    """A monomial whose dressed coefficients cannot be derived (the message says why)."""


def check_monomial(a, b, error: type[ValueError] = ExpansionError) -> tuple[int, int]:
    """(a, b) as ints for the monomial u^a v^b, or ``error`` saying what is wrong with them."""
    for name, val in (("a", a), ("b", b)):
        if isinstance(val, bool) or not isinstance(val, (int, np.integer)) or val < 0:
            raise error(f"monomial exponent {name} must be an integer >= 0, got {val!r}")
    if a + b == 0:
        raise error("the constant monomial (a = b = 0) moves the chain at rest: it has no law")
    return int(a), int(b)


def first_order_rate(a: int, b: int, n: float) -> float:
    """k1 = -w_ab / ((n + 1) E_1): d ln A/di = -k1 x (energy balance, derive/balance.py)."""
    from pulsemap.symbolic.balance import balance_constants  # mpmath integrals, cached
    from pulsemap.symbolic.balance_constants import integral_name

    name = integral_name("energy", a, b)
    c = balance_constants(["K1", "V1", name], n=n)
    return -c[name].value / ((n + 1) * (c["K1"].value + c["V1"].value))


def _hermite_matrix() -> np.ndarray:
    """Quintic Hermite coefficients a0..a5 (rows) from (f0, d0, c0, f1, d1, c1) (columns), derive/profile.py."""
    return np.array([[1, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0], [0, 0, 0.5, 0, 0, 0],
                     [-10, -6, -1.5, 10, -4, 0.5], [15, 8, 1.5, -15, 7, -1], [-6, -3, -0.5, 6, -3, 0.5]])


class WaveBase:
    """The exact travelling wave of scale 1 on ``beads`` beads, contact ``centre`` at its peak at t = 0:
    strains d0_j = S(t + centre - j), bead displacements x0_i = sum_{k >= i} d0_k and velocities v0_i."""

    def __init__(self, n: float, beads: int, centre: int):
        prof = exact_profile(float(n))
        self.nodes, self.h, self.tau0 = prof.nodes, prof.h, prof.tau0
        self.beads, self.centre = beads, centre
        self.coef = _hermite_matrix()

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        from pulsemap.solvers.models.dressed_kernel import wave  # compiled: numba loads only when it runs

        return wave(float(t), self.nodes, self.h, self.tau0, self.centre, NPU, self.coef, self.beads)


def expansion_orbits(monomials, pairs, n: float, *, cut: float, settle: int, span: int, rtol: float):
    """(contacts, alpha, beta, first) for eps R = sum_j c_j u^a_j v^b_j: ln P_k = ln S0 + sum_j c_j alpha_jk
    + sum_(j,l) in pairs c_j c_l beta_(jl)k (j <= l), contacts first - 1 .. first + settle + span + 1. The
    second order of a pair j < l: z'' = F'(d0) zeta + F''(d0) eta_j eta_l + m (R_j,u y_l + R_j,v y_l' + (j <-> l));
    j = l: the module docstring's equation."""
    prof = exact_profile(float(n))
    S0, S2, nn = prof.S0, float(prof.d2S(0.0)), float(n)
    min_c = int(math.ceil(prof.tail)) + 2
    centre = min_c + 1
    first = centre + 8
    last = first + settle + span + 1
    beads = last + min_c + 2
    mask = np.zeros(beads)
    mask[first - 1:] = 1.0
    floor = cut * S0 if nn < 2 else 0.0  # F'' is bounded for n >= 2: no taper (cut ignored)
    base = WaveBase(nn, beads, centre)
    M, P = len(monomials), len(pairs)
    from pulsemap.solvers.models.dressed_kernel import expansion_rhs  # compiled: numba loads only when it runs

    monos = np.array(monomials, dtype=np.int64).reshape(M, 2)
    pair_index = np.array(pairs, dtype=np.int64).reshape(P, 2)

    def rhs(t, Y):
        return expansion_rhs(t, Y, base.nodes, base.h, base.tau0, centre, NPU, base.coef, beads, nn, floor, mask,
                             monos, pair_index)

    ks = np.arange(first - 1, last + 1)
    times = (ks - centre).astype(float)
    from scipy.integrate import solve_ivp  # scipy loads only when the expansion runs

    sol = solve_ivp(rhs, (0.0, float(times[-1])), np.zeros(2 * (M + P) * beads), method="DOP853", rtol=rtol,
                    atol=rtol * 1e-3, t_eval=times)
    if sol.status != 0 or sol.y.shape[1] != ks.size:
        raise ExpansionError(f"the expansion about the solitary wave could not be integrated (cut {cut:g}): "
                             f"{sol.message}")
    alpha = np.empty((M, ks.size))
    beta = np.empty((P, ks.size))
    for m, k in enumerate(ks):
        Y = sol.y[:, m].reshape(2 * (M + P), beads)
        strain = Y[0::2, k - 1] - Y[0::2, k]
        rate = Y[1::2, k - 1] - Y[1::2, k]
        alpha[:, m] = strain[:M] / S0
        for q, (j, l) in enumerate(pairs):
            shift = rate[j] * rate[l] / S2 * (0.5 if j == l else 1.0)
            beta[q, m] = (strain[M + q] - shift) / S0 - alpha[j, m] * alpha[l, m] * (0.5 if j == l else 1.0)
    return ks, alpha, beta, first


def chain_coefficients(a: int, b: int, n: float, *, cut: float, settle: int = 12, span: int = 12,
                       rtol: float = 1e-10) -> dict:
    """Per step k (contacts first-1 .. last): k1_k, rho_k = k2_k/k1_k and the lag Delta_k (module docstring)."""
    ks, alphas, betas, first = expansion_orbits(((a, b),), ((0, 0),), n, cut=cut, settle=settle, span=span,
                                                rtol=rtol)
    alpha, beta = alphas[0], betas[0]
    e = scaling_exponent(a, b, n)
    k1 = -(alpha[1:] - alpha[:-1])
    if not np.all(np.isfinite(k1)) or abs(k1[-1]) < 1e-300:
        raise ExpansionError(f"u^{a} v^{b} does no work on the wave (k1 = 0): no decay law to dress")
    k2 = -(beta[1:] - beta[:-1]) - k1 * e * (alpha[1:] + alpha[:-1]) / 2
    lag = (ks - (first - 1)) + (alpha - alpha[0]) / k1[-1]
    return {"steps": ks[:-1], "k1": k1, "rho": k2 / k1, "lag": lag[1:], "first": first}


def chain_cross(first_mono: tuple[int, int], second_mono: tuple[int, int], n: float, *, cut: float,
                settle: int = 12, span: int = 12, rtol: float = 1e-10) -> dict:
    """Per step k the cross coefficient k2_jl of c_j u^a v^b + c_l u^a' v^b' (x at the step's mid-point):
    k2_jl = -(beta_(jl)k+1 - beta_(jl)k) - k1_j e_j abar_l - k1_l e_l abar_j, abar = (alpha_k + alpha_k+1)/2."""
    ks, alpha, beta, _ = expansion_orbits((first_mono, second_mono), ((0, 1),), n, cut=cut, settle=settle,
                                          span=span, rtol=rtol)
    k1 = -(alpha[:, 1:] - alpha[:, :-1])
    mid = (alpha[:, 1:] + alpha[:, :-1]) / 2
    e1, e2 = scaling_exponent(*first_mono, n), scaling_exponent(*second_mono, n)
    k2 = -(beta[0, 1:] - beta[0, :-1]) - k1[0] * e1 * mid[1] - k1[1] * e2 * mid[0]
    return {"steps": ks[:-1], "k2": k2, "k1": k1}


# ------------------------------------------------------------ part 2: the derived coefficients
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


def stored(key: str) -> dict | None:
    """The entry ``key`` from the cache, else from the shipped coefficients (None: neither has it)."""
    return cache.load_or_shipped(NAMESPACE, key, SHIPPED)


def is_derived(a: int, b: int, n: float = 1.5) -> bool:
    """Whether derive_monomial has u^a v^b at exponent n cached or shipped (nothing to integrate)."""
    return stored(cache_key(a, b, float(n))) is not None


def derive_monomial(a: int, b: int, n: float = 1.5, use_cache: bool = True) -> DerivedMonomial:
    """k2/k1 and the onset lag of c u^a v^b at exponent n from the expansion (module docstring); cached."""
    (a, b), n = check_monomial(a, b), float(n)
    key = cache_key(a, b, n)
    if use_cache:
        hit = stored(key)
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
        hit = stored(key) or stored(swapped)
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


def write_shipped(monomials=((1, 0), (3, 0), (0, 1), (2, 1)),
                  pairs=(((1, 0), (0, 1)), ((1, 0), (2, 1)), ((0, 1), (2, 1)), ((1, 0), (3, 0)), ((3, 0), (0, 1))),
                  n: float = 1.5) -> Path:
    """Recompute (no cache) the derived coefficients of the paper's monomials and pairs (and u + u^3 + v's) and
    write SHIPPED."""
    table = {cache_key(a, b, n): derive_monomial(a, b, n, use_cache=False).as_dict() for a, b in monomials}
    for p, q in pairs:
        table[cross_key(p, q, n)] = derive_cross(p, q, n, use_cache=False).as_dict()
    SHIPPED.write_text(json.dumps(table, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    return SHIPPED
