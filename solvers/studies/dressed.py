"""``derive --model dressed`` and its API: the dressed law of a perturbation (derive/dressed.py).

k1 per monomial is derived (the energy balance's profile integral, mpmath); k2/k1, the onset lag and
the cross terms k2_jl of every pair are derived by expanding Eq. 1 to second order about the exact
solitary wave (solvers/models/dressed_expansion.py, cached; the paper's monomials ship precomputed),
with DNS calibrations (``calibrate``, below) as the fallback where the expansion fails
(``source="calibrated"`` asks for them). The next term of the decrement (the validity bound) is
calibrated only. The law in closed form needs a uniform polynomial R; for a site-dependent R ``run`` follows the
coefficients c_j(i) (bead i + 1/2 at contact index i) numerically; a non-polynomial R has no
monomials (use the energy balance by quadrature).

The calibration (``calibrate``, ``calibrate_cross``, last section). Second-order ("dressed") coefficients of one monomial measured by DNS decrements (calibrated, not derived).

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
import time
from dataclasses import asdict, dataclass, field
from functools import lru_cache
from itertools import combinations
from pathlib import Path

import numpy as np
import sympy
from scipy.integrate import solve_ivp

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.symbolic import cache
from pulsemap.symbolic.balance import BalanceError, balance_expand, json_header
from pulsemap.symbolic.dressed import I as DRESSED_I
from pulsemap.symbolic.dressed import CrossTerm, DressedError, DressedLaw, DressedTerm
from pulsemap.symbolic.site_law import I as SITE_I
from pulsemap.symbolic.site_law import coefficient_of_i
from pulsemap.symbolic.expansion import bead_symbol
from pulsemap.symbolic.expression import symbol
from pulsemap.symbolic.perturbation import Perturbation
from pulsemap.symbolic.profile import check_exponent, exact_profile
from pulsemap.symbolic.scaling import scaling_exponent
from pulsemap.solvers.chain.equations import OnSiteForce
from pulsemap.solvers.chain.launch import launch, min_centre
from pulsemap.solvers.studies.workers import cores, fork_pool
from pulsemap.solvers.studies.errors import counted
from pulsemap.solvers.models.dressed import DressedCoefficients
from pulsemap.solvers.models.dressed_expansion import (ExpansionError, check_monomial, derive_cross, derive_monomial,
                                                       first_order_rate, is_derived)

MAX_BEAD_STEP = 0.05  # largest change of a coefficient from one bead to the next, over its largest |value|
BEAD_SPAN = 100  # beads after the first perturbed one over which a run's law checks that its coefficients are slow
CROSS_NOTE = "a cross term k2_jl x_j x_l could be neither derived nor calibrated: the law neglects it"
SOURCES = ("derived", "calibrated")


def _calibration_ahead(a: int, b: int, n: float):
    """calibrate(a, b, n) running in a forked process (studies/workers.py) while this one derives the
    monomial, when neither is cached (each takes seconds from empty caches) and a second core can take it;
    else None."""
    key = cache_key(*check_monomial(a, b, CalibrationError), float(n))
    if cores() < 2 or is_derived(a, b, n) or _stored(key) is not None:
        return None
    pool = fork_pool(1)
    if pool is None:
        return None
    job = pool.submit(calibrate, a, b, n)
    pool.shutdown(wait=False)  # the worker ends once the calibration is done
    return job


def monomial_coefficients(a: int, b: int, n: float, source: str = "derived") -> dict:
    """k2/k1, the onset lag and the next term of u^a v^b with their provenance: derived (the expansion) unless
    ``source`` is "calibrated" or the expansion fails; the next term always from the calibration (None when it
    cannot be calibrated but the rest was derived)."""
    out, why = {}, None
    ahead = _calibration_ahead(a, b, n) if source == "derived" else None
    try:
        if source == "derived":
            try:
                d = derive_monomial(a, b, n)
                out = {"rho": d.k2_over_k1, "rho_error": d.k2_over_k1_error,
                       "rho_method": d.label("rho") + f"; {d.method}",
                       "lag": d.onset_lag, "lag_error": d.onset_lag_error, "lag_method": d.label("lag")}
            except ExpansionError as exc:
                why = str(exc)
        fit = calibrate(a, b, n) if ahead is None else ahead.result()
    except CalibrationError:
        if not out:
            raise
        return {**out, "next_kind": "x^2", "next": 0.0}
    finally:
        if ahead is not None:
            ahead.cancel()
    if not out:
        out = {"rho": fit.k2_over_k1, "rho_error": fit.k2_over_k1_error,
               "rho_method": fit.method + (f" (not derived: {why})" if why else ""),
               "lag": fit.onset_lag, "lag_error": fit.onset_lag_error,
               "lag_method": f"calibrated: same runs, lag of the DNS behind the law, straight line in x0 to x0 = 0 "
                             f"(slope {fit.onset_lag_slope:.3g})"}
    return {**out, "k1": fit.k1, "next_kind": "|x|^(3/2)" if fit.g is not None else "x^2",
            "next": fit.g if fit.g is not None else fit.r1}


def cross_coefficient(p: DressedTerm, q: DressedTerm, n: float, source: str = "derived") -> CrossTerm:
    """k2_jl of a pair: derived unless ``source`` is "calibrated" or the expansion fails; else calibrated."""
    if source == "derived":
        try:
            d = derive_cross(p.exponents, q.exponents, n)
            return CrossTerm(p.monomial, q.monomial, d.k2, d.error,
                             f"derived (mixed second order of the expansion; accuracy +-{d.error:.2g}); {d.method}")
        except ExpansionError:
            pass
    try:
        cf = calibrate_cross(p.exponents, q.exponents, n)
        return CrossTerm(p.monomial, q.monomial, cf.k2, cf.error, cf.method)
    except CalibrationError as exc:
        return CrossTerm(p.monomial, q.monomial, None, None, f"not computed: {exc}")


@dataclass(frozen=True)
class DressedDerivation:
    """The dressed law of one perturbation, with the choices and timings that produced it."""

    perturbation: Perturbation
    n: float
    law: DressedLaw
    A0: float | None = None
    i0: float = 0.0
    timings_s: dict = field(default_factory=dict)

    def coefficients(self) -> DressedCoefficients:
        return coefficients(self.law)

    def to_dict(self) -> dict:
        """The JSON document of ``pulsemap derive --model dressed --json``."""
        return to_json(self)

    @property
    def latex(self) -> str:
        return self.law.latex()

    def __str__(self) -> str:
        return to_text(self)

    def __repr__(self) -> str:
        holds = f"{counted(len(self.law.terms), 'monomial')}, {counted(len(self.law.cross), 'cross term')}"
        return (f"DressedDerivation(R={self.perturbation.text!r}, eps={self.perturbation.eps:g}, n={self.n:g}: "
                f"dressed law of {holds})")


def coefficients(law: DressedLaw) -> DressedCoefficients:
    """The law's numbers for the evaluator (solvers/models/dressed.py)."""
    names = [t.monomial for t in law.terms]
    cross = tuple((names.index(ct.first), names.index(ct.second), ct.k2) for ct in law.cross if ct.k2 is not None)
    return DressedCoefficients(
        c=tuple(t.c for t in law.terms), e=tuple(float(t.e) for t in law.terms), k1=tuple(t.k1 for t in law.terms),
        rho=tuple(t.rho for t in law.terms), lag=tuple(t.lag for t in law.terms),
        x_bound=tuple(t.x_bound()[0] for t in law.terms), cross=cross,
        next_coef=tuple(t.next_coefficient for t in law.terms),
        next_power=tuple(1.5 if t.next_kind == "|x|^(3/2)" else 2.0 for t in law.terms),
        monomials=tuple(tuple(t.exponents) for t in law.terms))


def coefficient_at(coefficient: sympy.Expr, pert: Perturbation, bead: float) -> float:
    """A monomial's coefficient in R (bead-indexed parameters, i) at a bead position (continuous)."""
    sub = {symbol("i"): sympy.Float(bead, 17)}
    sub.update(pert.scalar_values())
    for name in pert.site_dependent:
        sub[bead_symbol(name, 0)] = sympy.Float(float(pert.values_at(name, [bead])[0]), 17)
    return float(sympy.sympify(coefficient).xreplace(sub))


def coefficient_along(coefficient: sympy.Expr, pert: Perturbation, beads: np.ndarray) -> np.ndarray:
    """coefficient_at at every bead position of ``beads`` at once (one lambdified numpy evaluation)."""
    site = list(pert.site_dependent)
    expr = sympy.sympify(coefficient).xreplace(pert.scalar_values())
    f = sympy.lambdify([symbol("i"), *(bead_symbol(name, 0) for name in site)], expr, "numpy")
    with np.errstate(all="ignore"):
        vals = f(beads, *(pert.values_at(name, beads) for name in site))
    return np.broadcast_to(np.asarray(vals, dtype=float), beads.shape).copy()


def bead_to_bead(coefficient: sympy.Expr, monomial: str, pert: Perturbation, first_bead: float) -> str:
    """Why the dressed law cannot follow a coefficient that jumps from bead to bead ("" when it can): its rate
    is local in the contact index, while a bead acts on the pulse over several contacts (the relaxed model's
    response kernel), so the law holds where the coefficient changes by <= MAX_BEAD_STEP of its largest
    value from one bead to the next (checked over BEAD_SPAN beads from ``first_bead``)."""
    vals = coefficient_along(coefficient, pert, first_bead + np.arange(BEAD_SPAN + 1.0))
    scale = float(np.max(np.abs(vals)))
    step = float(np.max(np.abs(np.diff(vals)))) / scale if scale > 0 and np.all(np.isfinite(vals)) else 0.0
    if step <= MAX_BEAD_STEP:
        return ""
    return (f"the coefficient of {monomial} changes by up to {100 * step:.0f} % of its largest value from one bead to "
            f"the next (the law holds where it changes by <= {100 * MAX_BEAD_STEP:g} %: a bead acts on the pulse over "
            "several contacts); use method relaxed")


def site_coefficient_functions(pert: Perturbation, law: DressedLaw, i0: float, i1: float, step: float = 1 / 16):
    """c_j(i) = eps R's coefficient of monomial j at bead i + 1/2 (the energy law's convention, derive/site_law.py),
    tabulated from i0 to i1 and interpolated linearly: one function per term of ``law``."""
    ex = balance_expand(pert.R, law.n, "energy", pert.site_dependent)
    coefs = {str(t.monomial): t.coefficient for t in ex.terms}
    grid = np.arange(i0, i1 + 2 * step, step)
    out = []
    for t in law.terms:
        vals = float(pert.eps) * coefficient_along(coefs[t.monomial], pert, grid + 0.5)
        out.append(lambda i, vals=vals: float(np.interp(i, grid, vals)))
    return tuple(out)


def dressed_law(pert: Perturbation, n: float = 1.5, at_bead: float | None = None, source: str = "derived",
                i0: float = 0.0) -> DressedLaw:
    """Expand eps R into monomials, derive (or calibrate) each one (cached) and form the law. A site-dependent R:
    with ``at_bead`` its coefficients are taken at that bead (``run`` follows c_j(i) along the chain with
    ``site_coefficient_functions``); without, each term carries c_j(i) (the energy law's convention, bead
    i + 1/2; derive/site_law.py) and its value at i0. k1, k2/k1 and the lag do not depend on c."""
    n = check_exponent(n)
    if source not in SOURCES:
        raise DressedError(f"unknown coefficient source {source!r}: choose one of {', '.join(SOURCES)}")
    site = not pert.is_uniform and at_bead is None  # derive: c_j(i) in the law, its value at i0 for the onset
    if site:
        at_bead = float(i0) + 0.5  # contact index i0 meets bead i0 + 1/2 (the energy law's convention)
    try:
        ex = balance_expand(pert.R, n, "energy", pert.site_dependent)
    except BalanceError as exc:
        raise DressedError(f"the dressed law expands R into monomials: {exc}") from None
    terms = []
    eps = float(pert.eps)
    for t in ex.terms:
        a, b = t.exponents
        if pert.is_uniform:
            value = float(sympy.sympify(t.coefficient).xreplace(pert.scalar_params()))
            if value == 0:
                continue
        else:
            value = coefficient_at(t.coefficient, pert, float(at_bead))
            if not site:  # a run follows c_j(i) along the chain: only where it changes slowly from bead to bead
                why = bead_to_bead(t.coefficient, str(t.monomial), pert, float(at_bead) + 0.5)
                if why:
                    raise DressedError(why)
        try:
            co = monomial_coefficients(a, b, n, source)
        except (CalibrationError, ExpansionError) as exc:
            raise DressedError(f"monomial {t.monomial}: {exc}") from None
        s = (sympy.Rational(str(n)) - 1) / 2
        e = a + (1 + s) * b - 1 - 2 * s
        c_of_i = None
        if site:
            c_of_i = sympy.nsimplify(eps) * coefficient_of_i(t.coefficient, pert, "energy").xreplace({SITE_I: DRESSED_I})
        terms.append(DressedTerm(
            c_of_i=c_of_i,
            monomial=str(t.monomial), exponents=(a, b), c=eps * value, e=sympy.nsimplify(e),
            k1=co.get("k1", first_order_rate(a, b, n)),
            k1_method="derived: energy balance, -w_ab/((n+1) E_1), mpmath integrals",
            rho=co["rho"], rho_error=co["rho_error"], rho_method=co["rho_method"],
            lag=co["lag"], lag_error=co["lag_error"], lag_method=co["lag_method"],
            next_kind=co["next_kind"], next_coefficient=co["next"],
        ))
    if not terms:  # R = 0 or no term does work: the law is A constant
        return DressedLaw(n=n, terms=(), cross=(), notes=(f"R = {pert.text} does no work on the wave: A stays constant",))
    cross = [cross_coefficient(p, q, n, source) for p, q in combinations(terms, 2)]
    notes = (CROSS_NOTE,) if any(ct.k2 is None for ct in cross) else ()
    calibrated = [t.monomial for t in terms if t.rho_method.startswith("calibrated")]
    calibrated += [f"{ct.first} x {ct.second}" for ct in cross if ct.method.startswith("calibrated")]
    if calibrated:
        notes += (f"calibrated (fitted to DNS decrements of launched solitons), not derived: {', '.join(calibrated)}",)
    notes += ("k1 is the energy balance; k2/k1, the onset lag and the cross terms are derived by expanding Eq. 1 to "
              "second order about the exact wave (unless marked calibrated); the next term (validity bound) is "
              "calibrated",)
    return DressedLaw(n=n, terms=tuple(terms), cross=tuple(cross), notes=notes)


def derive_dressed(pert: Perturbation, n: float = 1.5, A0_value: float | None = None, i0: float = 0.0,
                   source: str = "derived", **ignored) -> DressedDerivation:
    """``derive --model dressed``: the dressed law of ``pert`` (module docstring)."""
    for option in ("variant", "fold"):
        if ignored.get(option) is not None:
            raise DressedError(f"--{option} applies to the map only, not to the dressed law: drop it or use --model map")
    if ignored.get("profile") not in (None, "exact"):
        raise DressedError("the dressed law uses the exact profile (its DNS launches exact solitons): drop --profile")
    if A0_value is not None and not A0_value > 0:
        raise DressedError(f"the initial amplitude A0 must be > 0, got {A0_value}")
    if pert.free_parameters:  # its second-order coefficients are numbers (DNS fits or numeric expansions)
        names = pert.free_parameters
        raise DressedError(f"the dressed law needs a value for {', '.join(names)}: give "
                           + " ".join(f"--param {name}=VALUE" for name in names)
                           + f"; --model energy derives the energy law with {', '.join(names)} symbolic")
    t0 = time.perf_counter()
    law = dressed_law(pert, n, source=source, i0=i0)
    return DressedDerivation(pert, float(n), law, A0_value, i0, {"total": time.perf_counter() - t0})


def to_json(d: DressedDerivation) -> dict:
    return {**json_header("dressed", d.perturbation), "n": d.n, "profile": "exact",
            "dressed": d.law.data(d.A0, d.i0), "timings_s": {k: round(v, 6) for k, v in d.timings_s.items()}}


def to_text(d: DressedDerivation) -> str:
    head = ["Model: dressed law (energy balance + second order)",
            f"R(u, v) = {d.perturbation.R}    eps = {d.perturbation.eps:g}    n = {d.n:g}    profile = exact", ""]
    return "\n".join(head + d.law.lines(d.A0, d.i0))


def to_latex(d: DressedDerivation) -> str:
    return f"% pulsemap derivation, model: dressed law; R = {d.perturbation.R}\n" + d.law.latex()


# ----------------------- the calibration: second-order coefficients measured by DNS decrements
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


@lru_cache(maxsize=1)
def shipped() -> dict:
    """Calibrations shipped with pulsemap (SHIPPED, written by ``write_shipped``: the monomials of the paper's
    scenes at n = 3/2), by cache key; an entry whose key no longer matches the method is never used."""
    try:
        return json.loads(SHIPPED.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}


def _stored(key: str) -> dict | None:
    """The calibration ``key`` from the cache, else from the shipped ones (None: neither has it)."""
    return cache.load(NAMESPACE, key) or shipped().get(key)


def write_shipped(monomials=((1, 0), (3, 0), (0, 1), (2, 1)), pairs=(((1, 0), (0, 1)), ((1, 0), (2, 1)), ((0, 1), (2, 1))),
                  n: float = 1.5, use_cache: bool = False) -> Path:
    """Recompute the shipped calibrations (no cache unless ``use_cache``) and write SHIPPED: the monomials and
    pairs of the paper's scenes (the Van der Pol R = -(u - mu (1 - u^2) v) has all three pairs)."""
    table = {cache_key(a, b, n): calibrate(a, b, n, use_cache=use_cache).as_dict() for a, b in monomials}
    for p, q in pairs:
        fit = calibrate_cross(p, q, n, use_cache=use_cache)
        table[cross_key(p, q, n)] = fit.as_dict()
    SHIPPED.write_text(json.dumps(table, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    shipped.cache_clear()
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
        hit = _stored(key)
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
        hit = _stored(key)
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
