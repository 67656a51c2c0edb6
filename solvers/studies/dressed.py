"""``derive --model dressed`` and its API: the dressed law of a perturbation (derive/dressed.py).

k1 per monomial is derived (the energy balance's profile integral, mpmath); k2/k1, the onset lag and
the cross terms k2_jl of every pair are derived by expanding Eq. 1 to second order about the exact
solitary wave (solvers/models/dressed_expansion.py, cached; the paper's monomials ship precomputed),
with DNS calibrations (``calibrate``, solvers/studies/dressed_calibration.py) as the fallback where the
expansion fails (``source="calibrated"`` asks for them). The next term of the decrement (the validity bound) is
calibrated only. The law in closed form needs a uniform polynomial R; for a site-dependent R ``run`` follows the
coefficients c_j(i) (bead i + 1/2 at contact index i) numerically; a non-polynomial R has no
monomials (use the energy balance by quadrature).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from itertools import combinations

import numpy as np
import sympy

from pulsemap.symbolic.balance import BalanceError, balance_expand, json_header
from pulsemap.symbolic.dressed import I as DRESSED_I
from pulsemap.symbolic.dressed import CrossTerm, DressedError, DressedLaw, DressedTerm
from pulsemap.symbolic.site_law import I as SITE_I
from pulsemap.symbolic.site_law import coefficient_of_i
from pulsemap.symbolic.expansion import bead_symbol
from pulsemap.symbolic.expression import symbol
from pulsemap.symbolic.perturbation import Perturbation
from pulsemap.symbolic.profile import check_exponent
from pulsemap.solvers.studies.workers import cores, fork_pool
from pulsemap.solvers.studies.errors import counted
from pulsemap.solvers.studies.dressed_calibration import (CalibrationError, cache_key, calibrate, calibrate_cross,
                                                          stored)
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
    if cores() < 2 or is_derived(a, b, n) or stored(key) is not None:
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
