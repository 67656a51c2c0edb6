"""The DNS calibration of the dressed law (studies/dressed.py forms the law): second-order ("dressed")
coefficients of one monomial (``calibrate``) and of a pair (``calibrate_cross``) measured by DNS decrements
(calibrated, not derived).

For R = c u^a v^b the energy balance gives the first-order decay d ln A/di = -k1 x, x = c A^e,
k1 = -w_ab / ((n + 1) E_1), e = a + (1 + s) b - 1 - 2 s (derive/balance.py, s = (n - 1)/2). The next
order is measured here, never assumed:

1. An exact solitary wave (solvers/chain/launch.py) of scale A0 = 1 is launched with contact
   ``CENTRE`` at its peak; beads >= first = CENTRE + 8 carry eps R = c u^a v^b. No kick transient.
2. For each c of a ladder of small |x0| = |c| A0^e, the peaks P_k give decrements
   delta_k = ln(P_k / P_{k+1}) at the geometric mid-point A = sqrt(A_k A_{k+1}) (A = P / S(0)),
   x = c A^e, and y = delta / (k1 x) - 1, over contacts >= first + SETTLE (the onset transient has
   relaxed there: y is constant along the chain to 1e-4 for v, measured).
3. Least squares over all points: y = r0 x + r1 x^2 when b >= 1 (smooth in x), and
   y = r0 x + g |x|^(3/2) + r1 x^2 for a foundation (b = 0: the wake behind the pulse is displaced
   by A D and the foundation acts on it). Only the sign of c where the pulse decays (k1 x > 0) is
   used, except for pure velocity terms v^b (both signs): with the other sign the displaced wake is
   unstable (R = +c u: exponential, R = +c u^2 v: blow-up in finite time). k2/k1 = r0 = lim y/x.
   Its error: the larger of the fit's standard error and the change of r0 when the largest |x0| is
   left out, plus the fit model's truncation (the change of r0 when an x^3 term is added: 8e-4 for
   u^2 v, 0.2 for u^3, where the two-term fit leaves rung-by-rung residuals).
4. Onset lag: the law d ln A/di = -k1 x (1 + y(x)) integrated from the DNS peak at contact
   first - 1 (where a run seeds its models) runs ahead of the DNS by a lag: past the transient
   ln A_DNS(i) = ln A_law(i - Delta), i.e. Delta = (ln A_DNS - ln A_law) / (k1 x (1 + y)) at the law's
   own x (constant along the chain to 1e-4, measured); Delta_0 is the intercept of a straight line
   in x0 (x at the seed) over the ladder. Its error adds the spread along the chain, the change
   of Delta_0 with the x^3-extended y(x) and with a parabola in x0 instead of the line (foundations:
   Delta curves steeply towards x0 = 0, u^3: 1.753 at |x0| = 0.001, 1.716 at 0.002).

Each monomial costs 4-7 launches (~5-30 s) and is cached on disk (namespace "dressed"); the monomials of
the paper's scenes (u, u^3, v, u^2 v at n = 3/2) ship precomputed in solvers/data/dressed_calibration.json
(``write_shipped`` recomputes them; a test recomputes v and compares).
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.symbolic import cache
from pulsemap.symbolic.profile import exact_profile
from pulsemap.symbolic.scaling import scaling_exponent
from pulsemap.solvers.chain.equations import OnSiteForce
from pulsemap.solvers.chain.launch import launch, min_centre
from pulsemap.solvers.models.dressed_expansion import check_monomial, first_order_rate

NAMESPACE = "dressed"
SHIPPED = Path(__file__).resolve().parents[1] / "data" / "dressed_calibration.json"
METHOD_VERSION = 3
SETTLE = 20  # contacts after the first perturbed bead before decrements are used
SPAN = 40  # contacts measured after SETTLE
RTOL = 1e-11
SMOOTH_LADDER = (0.001, 0.002, 0.005, 0.01)  # |x0| for b >= 1: both signs, the growing one without the largest
FOUNDATION_LADDER = (0.001, 0.002, 0.004, 0.008, 0.016)  # |x0| for b = 0, restoring sign only


class CalibrationError(PulsemapError):
    """A monomial that cannot be calibrated (the message says why)."""


@dataclass(frozen=True)
class MonomialFit:
    """The measured second-order coefficients of c u^a v^b (n, k1 derived; the rest fitted)."""

    a: int
    b: int
    n: float
    k1: float  # derived: energy balance
    e: float  # x = c A^e
    k2_over_k1: float  # fitted: lim y/x
    k2_over_k1_error: float
    g: float | None  # fitted |x|^(3/2) coefficient of y (foundations), None for b >= 1
    r1: float  # fitted x^2 coefficient of y
    onset_lag: float  # fitted: Delta at x0 -> 0, contacts
    onset_lag_error: float
    onset_lag_slope: float  # dDelta/dx0
    x_range: tuple[float, float]  # smallest and largest |x| of the points used
    points: int
    fit_rms: float  # rms residual of the y fit
    method: str

    def as_dict(self) -> dict:
        return asdict(self)


def _ladder(a: int, b: int, k1: float) -> tuple[float, ...]:
    sign = 1.0 if k1 > 0 else -1.0  # decaying (restoring): k1 x > 0
    if b >= 1 and a == 0:  # the growing sign too: the wake at rest feels no force
        return tuple(sign * v for v in SMOOTH_LADDER) + tuple(-sign * v for v in SMOOTH_LADDER[:-1])
    if b >= 1:  # u^a v^b with a >= 1, growing sign: the displaced wake is anti-damped and blows up
        return tuple(sign * v for v in SMOOTH_LADDER)
    return tuple(sign * v for v in FOUNDATION_LADDER)


def _calibration_chain(n: float) -> tuple[int, int, int, int, np.ndarray]:
    """(centre of the launched wave, first perturbed bead, last contact, beads, mask of the perturbed
    beads) of a calibration run at exponent n."""
    centre = min_centre(n) + 1
    first = centre + 8
    last = first + SETTLE + SPAN
    beads = last + 6
    mask = np.zeros(beads)
    mask[first - 1:] = 1.0
    return centre, first, last, beads, mask


def _run(a: int, b: int, n: float, c: float):
    centre, first, last, beads, mask = _calibration_chain(n)
    force = OnSiteForce(force=lambda x, v: mask * (c * x**a * v**b))
    res = launch(beads, n, 1.0, centre, (first - 1, last), force, rtol=RTOL)
    if any(p is None for p in res.peaks):
        raise CalibrationError(f"the launched pulse was lost with R = {c:g} u^{a} v^{b}: take a smaller |x|")
    return first, np.array(res.contacts), np.array(res.peaks, dtype=float)


def _design(x: np.ndarray, foundation: bool, extended: bool = False) -> np.ndarray:
    cols = [x, np.abs(x) ** 1.5, x**2] if foundation else [x, x**2]
    return np.stack(cols + [x**3] if extended else cols, axis=1)


def _fit(x: np.ndarray, y: np.ndarray, foundation: bool, extended: bool = False) -> tuple[np.ndarray, float, float]:
    M = _design(x, foundation, extended)
    coef, *_ = np.linalg.lstsq(M, y, rcond=None)
    res = y - M @ coef
    dof = max(1, len(y) - M.shape[1])
    cov = np.linalg.inv(M.T @ M) * float(res @ res) / dof
    return coef, float(math.sqrt(max(cov[0, 0], 0.0))), float(np.sqrt(np.mean(res**2)))


def cache_key(a: int, b: int, n: float) -> str:
    """Everything a calibration depends on (method version, n, monomial, ladder, window, tolerance)."""
    return (f"dressed-v{METHOD_VERSION}|n={float(n)!r}|a={int(a)}|b={int(b)}|settle={SETTLE}|span={SPAN}|rtol={RTOL}"
            f"|smooth={SMOOTH_LADDER}|foundation={FOUNDATION_LADDER}")


def stored(key: str) -> dict | None:
    """The calibration ``key`` from the cache, else from the shipped ones (SHIPPED, written by ``write_shipped``:
    the monomials of the paper's scenes at n = 3/2; an entry whose key no longer matches the method is never
    used), None: neither has it."""
    return cache.load_or_shipped(NAMESPACE, key, SHIPPED)


def write_shipped(monomials=((1, 0), (3, 0), (0, 1), (2, 1)), pairs=(((1, 0), (0, 1)), ((1, 0), (2, 1)), ((0, 1), (2, 1))),
                  n: float = 1.5, use_cache: bool = False) -> Path:
    """Recompute the shipped calibrations (no cache unless ``use_cache``) and write SHIPPED: the monomials and
    pairs of the paper's scenes (the Van der Pol R = -(u - mu (1 - u^2) v) has all three pairs)."""
    table = {cache_key(a, b, n): calibrate(a, b, n, use_cache=use_cache).as_dict() for a, b in monomials}
    for p, q in pairs:
        fit = calibrate_cross(p, q, n, use_cache=use_cache)
        table[cross_key(p, q, n)] = fit.as_dict()
    SHIPPED.write_text(json.dumps(table, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    return SHIPPED


def _onset_lag(runs, coef: np.ndarray, foundation: bool, k1: float, e: float, S0: float,
               extended: bool = False) -> tuple[float, float, float]:
    """Delta_0, dDelta/dx0 and the error of the onset lag (module docstring, step 4) with the fitted y(x)."""

    def y_of(xv: float) -> float:
        return float((_design(np.array([xv]), foundation, extended) @ coef)[0])

    lags, x0s, drift = [], [], []
    for x0, first, contacts, peaks in runs:
        A = peaks / S0
        i0 = first - 1
        A_seed = A[0]  # contact first - 1: where a run seeds its models

        def rhs(i, lnA, c=x0):
            xv = c * math.exp(lnA[0] * e)
            return [-k1 * xv * (1.0 + y_of(xv))]

        sol = solve_ivp(rhs, (i0, float(contacts[-1])), [math.log(A_seed)], rtol=1e-12, atol=1e-14,
                        t_eval=contacts.astype(float))
        D = np.log(A) - sol.y[0]
        tail = contacts >= first + SETTLE
        x_law = x0 * np.exp(sol.y[0] * e)
        rate = k1 * x_law * (1.0 + np.array([y_of(v) for v in x_law]))  # -d ln A/di of the law
        shift = D[tail] / rate[tail]  # a lag Delta: ln A_DNS(i) = ln A_law(i - Delta)
        lags.append(float(np.mean(shift)))
        drift.append(float(np.ptp(shift)))
        x0s.append(x0 * A_seed**e)
    x0s, lags = np.array(x0s), np.array(lags)
    M = np.stack([np.ones_like(x0s), x0s], axis=1)
    (lag0, slope), *_ = np.linalg.lstsq(M, lags, rcond=None)
    small = np.abs(x0s) < np.abs(x0s).max()
    (lag0_s, _), *_ = np.linalg.lstsq(M[small], lags[small], rcond=None)
    lag0_q = np.polyfit(x0s, lags, 2)[-1]  # the straight line's truncation: a parabola's intercept
    lag_err = (abs(float(lag0_s) - float(lag0)) + float(np.sqrt(np.mean((lags - M @ [lag0, slope]) ** 2)))
               + max(drift) + abs(float(lag0_q) - float(lag0)))
    return float(lag0), float(slope), float(lag_err)


def calibrate(a: int, b: int, n: float = 1.5, use_cache: bool = True) -> MonomialFit:
    """Measure k2/k1, g and the onset lag of c u^a v^b (module docstring); cached on disk."""
    (a, b), n = check_monomial(a, b, CalibrationError), float(n)
    key = cache_key(a, b, n)
    if use_cache:
        hit = stored(key)
        if hit is not None:
            hit = dict(hit)
            hit["x_range"] = tuple(hit["x_range"])
            return MonomialFit(**hit)
    S0 = exact_profile(n).S0
    k1 = first_order_rate(a, b, n)
    if k1 == 0:
        raise CalibrationError(f"u^{a} v^{b} does no work on the wave (k1 = 0): no decay law to dress")
    e = scaling_exponent(a, b, n)
    foundation = b == 0
    runs = []
    for x0 in _ladder(a, b, k1):
        first, contacts, peaks = _run(a, b, n, x0)  # A0 = 1: c = x0
        runs.append((x0, first, contacts, peaks))
    xs, ys, tags = [], [], []
    for x0, first, contacts, peaks in runs:
        A = peaks / S0
        use = contacts[:-1] >= first + SETTLE
        d = np.log(peaks[:-1] / peaks[1:])[use]
        xm = x0 * np.sqrt(A[:-1] * A[1:])[use] ** e
        xs.append(xm)
        ys.append(d / (k1 * xm) - 1.0)
        tags.append(np.full(xm.size, abs(x0)))
    x, y, tag = np.concatenate(xs), np.concatenate(ys), np.concatenate(tags)
    coef, se, rms = _fit(x, y, foundation)
    keep = tag < tag.max()
    coef_small, _, _ = _fit(x[keep], y[keep], foundation)
    coef_ext, _, _ = _fit(x, y, foundation, extended=True)  # the fit model's truncation: one more power
    r0 = float(coef[0])
    r0_err = max(se, abs(float(coef_small[0]) - r0)) + abs(float(coef_ext[0]) - r0)
    g = float(coef[1]) if foundation else None
    r1 = float(coef[-1])
    lag0, slope, lag_err = _onset_lag(runs, coef, foundation, k1, e, S0)
    lag_ext, _, _ = _onset_lag(runs, coef_ext, foundation, k1, e, S0, extended=True)
    lag_err += abs(lag_ext - lag0)
    fit = MonomialFit(
        a=a, b=b, n=n, k1=float(k1), e=float(e), k2_over_k1=r0, k2_over_k1_error=float(r0_err), g=g, r1=r1,
        onset_lag=lag0, onset_lag_error=lag_err, onset_lag_slope=slope,
        x_range=(float(np.abs(x).min()), float(np.abs(x).max())), points=int(x.size), fit_rms=rms,
        method=(f"calibrated: DNS of exact solitons (A0 = 1, rtol {RTOL:g}), {len(runs)} values of c, decrements "
                f"over contacts first+{SETTLE}..first+{SETTLE + SPAN}, least squares y = "
                + ("r0 x + g|x|^(3/2) + r1 x^2 (restoring sign only)" if foundation else "r0 x + r1 x^2")),
    )
    cache.store(NAMESPACE, key, fit.as_dict())
    return fit


# ----------------------------------------------------------------------------- cross terms
CROSS_LADDER = (0.002, 0.005, 0.01)  # |x0| of both monomials, each with its decaying sign


@dataclass(frozen=True)
class CrossFit:
    """The measured k2_jl of a pair of monomials: d = sum_j k1_j x_j (1 + y_j(x_j)) + k2_jl x_j x_l."""

    first: tuple[int, int]
    second: tuple[int, int]
    n: float
    k2: float
    error: float
    slope: float  # d(ratio)/d(|x_j| + |x_l|)
    points: int
    method: str

    def as_dict(self) -> dict:
        return asdict(self)


def _y_function(fit: MonomialFit):
    foundation = fit.g is not None
    coef = np.array([fit.k2_over_k1, fit.g, fit.r1] if foundation else [fit.k2_over_k1, fit.r1])
    return lambda x: _design(np.atleast_1d(x), foundation) @ coef


def cross_key(first, second, n: float) -> str:
    return f"cross-v2|{cache_key(*first, n)}|{cache_key(*second, n)}|ladder={CROSS_LADDER}"


def calibrate_cross(first: tuple[int, int], second: tuple[int, int], n: float = 1.5, use_cache: bool = True) -> CrossFit:
    """Measure k2_jl of c_j u^a v^b + c_l u^a' v^b' from launched solitons (both monomials calibrated alone
    first): the part of the decrement neither explains alone, divided by x_j x_l, extrapolated to x -> 0 along
    a straight line in |x_j| + |x_l|; error: the change when the largest rung is left out, the scatter, and the
    change with a parabola instead of the line (with a foundation the ratio curves towards 0: u x u^2 v per
    rung -2.115, -2.032, -1.930 at |x_j| + |x_l| = 0.004, 0.009, 0.017)."""
    (a1, b1), (a2, b2) = (tuple(int(v) for v in first), tuple(int(v) for v in second))
    n = float(n)
    key = cross_key((a1, b1), (a2, b2), n)
    if use_cache:
        hit = stored(key)
        if hit is not None:
            hit = dict(hit)
            hit["first"], hit["second"] = tuple(hit["first"]), tuple(hit["second"])
            return CrossFit(**hit)
    f1, f2 = calibrate(a1, b1, n), calibrate(a2, b2, n)
    y1, y2 = _y_function(f1), _y_function(f2)
    S0 = exact_profile(n).S0
    centre, first_bead, last, beads, mask = _calibration_chain(n)
    ratios, sums, tags = [], [], []
    for mag in CROSS_LADDER:
        c1 = mag * (1.0 if f1.k1 > 0 else -1.0)
        c2 = mag * (1.0 if f2.k1 > 0 else -1.0)
        force = OnSiteForce(force=lambda x, v, c1=c1, c2=c2: mask * (c1 * x**a1 * v**b1 + c2 * x**a2 * v**b2))
        res = launch(beads, n, 1.0, centre, (first_bead - 1, last), force, rtol=RTOL)
        if any(p is None for p in res.peaks):
            raise CalibrationError(f"the launched pulse was lost with both monomials at |x| = {mag:g}")
        peaks, contacts = np.array(res.peaks, dtype=float), np.array(res.contacts)
        A = peaks / S0
        use = contacts[:-1] >= first_bead + SETTLE
        d = np.log(peaks[:-1] / peaks[1:])[use]
        Am = np.sqrt(A[:-1] * A[1:])[use]
        x1, x2 = c1 * Am**f1.e, c2 * Am**f2.e
        alone = f1.k1 * x1 * (1 + y1(x1)) + f2.k1 * x2 * (1 + y2(x2))
        ratios.append((d - alone) / (x1 * x2))
        sums.append(np.abs(x1) + np.abs(x2))
        tags.append(np.full(d.size, mag))
    r, sm, tag = np.concatenate(ratios), np.concatenate(sums), np.concatenate(tags)
    M = np.stack([np.ones_like(sm), sm], axis=1)
    (k2, slope), *_ = np.linalg.lstsq(M, r, rcond=None)
    keep = tag < tag.max()
    (k2_s, _), *_ = np.linalg.lstsq(M[keep], r[keep], rcond=None)
    k2_q = np.polyfit(sm, r, 2)[-1]  # the straight line's truncation: a parabola's intercept
    err = (abs(float(k2_s) - float(k2)) + float(np.sqrt(np.mean((r - M @ [k2, slope]) ** 2)))
           + abs(float(k2_q) - float(k2)))
    fit = CrossFit((a1, b1), (a2, b2), n, float(k2), float(err), float(slope), int(r.size),
                   f"calibrated: {len(CROSS_LADDER)} launches with both monomials (decaying signs), residual decrement "
                   "over x_j x_l, straight line in |x_j| + |x_l| to 0")
    cache.store(NAMESPACE, key, fit.as_dict())
    return fit
