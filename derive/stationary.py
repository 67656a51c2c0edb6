"""Stationary shocks: Eq. 41 (A_{i-1} = A_i = A_{i+1} = A in the first map equation).

The contact terms cancel exactly (f1 - 2 f2 + f3 = S'(0) = 0), leaving

    Phi(A) = sum_p K_p A^p = 0,   K_p = sum_j c_j g^(1)_j   (eps cancels for uniform eps)

whose positive roots are the stationary amplitudes (peak = A S(0), Eq. 32). A saddle-node in a
parameter mu is where two roots meet: Phi = 0 and dPhi/dA = 0; we solve Phi = 0 for mu(A) and
locate the extrema of mu(A).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import reduce

import mpmath
import numpy as np
import sympy

from .errors import PulsemapError
from .amplitude_map import AmplitudeMap, integral_symbol
from .expression import symbol
from .longwave import needs_values
from .sympy_cache import bounded_cached

A = sympy.Symbol("A", positive=True)


class StationaryError(PulsemapError):
    """The stationary problem cannot be posed as asked."""


@dataclass(frozen=True)
class Fold:
    """A saddle-node of stationary shocks in parameter ``param``."""

    param: str
    value: float
    A: float
    peak: float
    kind: str  # "minimum" or "maximum" of param(A): roots exist above / below the value


@dataclass(frozen=True)
class Stationary:
    """Eq. 41 for one perturbation, its positive roots and (optionally) its fold."""

    equation: sympy.Expr  # Phi(A), symbolic constants
    numeric: sympy.Expr  # Phi(A), numeric
    roots: tuple[float, ...]
    S0: float
    fold: Fold | None = None
    folds: tuple[Fold, ...] = ()
    missing: tuple[str, ...] = ()  # free parameters (no value): no roots without them

    def peaks(self) -> tuple[float, ...]:
        return tuple(r * self.S0 for r in self.roots)


def multiplier_1d(amap: AmplitudeMap, numeric: sympy.Expr, root: float, eps: float) -> float:
    """dA_i/dA_{i-1} of the 1d map (Eq. 23 with A_{i+1} -> A_i, whose fixed points are exactly the
    roots of Eq. 41) at A_{i-1} = A_i = root:

        F = f1 A_{i-1}^P - (2 f2 - f3) A_i^P + eps Phi(A_i) = 0
        dA_i/dA_{i-1} = -F_{A_{i-1}} / F_{A_i} = f1 P A^(P-1) / ((2 f2 - f3) P A^(P-1) - eps Phi'(A)).

    |multiplier| < 1: the stationary shock attracts nearby amplitudes (stable)."""
    P = float(amap.P)
    f1, f2, f3 = (float(amap.constants[k]) for k in ("f1", "f2", "f3"))
    dphi = float(sympy.diff(numeric, A).subs(A, root)) if numeric != 0 else 0.0
    contact = P * root ** (P - 1)
    return f1 * contact / ((2 * f2 - f3) * contact - eps * dphi)


def _power_terms(amap: AmplitudeMap, params: dict) -> list[tuple[sympy.Rational, sympy.Expr]]:
    """(power, numeric coefficient expression) of Phi, in the parameters not substituted."""
    out = []
    values = {integral_symbol(k): sympy.Float(v, 17) for k, v in amap.constants.items()}
    for t in amap.power_terms(1, numeric=False):
        out.append((t.power, t.coefficient.xreplace(values).xreplace(params)))
    return out


def positive_roots(terms: list[tuple[sympy.Rational, float]], lo: float = 1e-9, hi: float = 1e9) -> tuple[float, ...]:
    """Positive roots of sum_p K_p A^p with rational powers p and float K_p."""
    terms = [(sympy.Rational(p), float(k)) for p, k in terms if float(k) != 0.0]
    if len(terms) < 2:
        return ()
    pmin = min(p for p, _ in terms)
    shifted = [(p - pmin, k) for p, k in terms]
    denom = reduce(math.lcm, (int(p.q) for p, _ in shifted), 1)
    degree = max(int(p * denom) for p, _ in shifted)
    cands: list[float] = []
    if degree <= 400:
        # A = x^denom turns Phi / A^pmin into a polynomial in x
        coeffs = np.zeros(degree + 1)
        for p, k in shifted:
            coeffs[degree - int(p * denom)] += k
        for x in np.roots(coeffs):
            if abs(x.imag) <= 1e-7 * abs(x) and x.real > 0:
                cands.append(float(x.real) ** denom)
    else:  # scan on a log grid
        grid = np.logspace(math.log10(lo), math.log10(hi), 4001)
        vals = sum(k * grid ** float(p) for p, k in shifted)
        for j in np.nonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))[0]:
            cands.append(float(math.sqrt(grid[j] * grid[j + 1])))

    def phi(a):
        return sum(k * mpmath.power(a, mpmath.mpf(p.p) / p.q) for p, k in shifted)

    roots = []
    with mpmath.workdps(30):
        for c in cands:
            if not (lo <= c <= hi):
                continue
            try:
                r = float(mpmath.findroot(phi, mpmath.mpf(c), tol=1e-25))
            except (ValueError, ZeroDivisionError):
                r = c
            if r > 0 and all(abs(r - q) > 1e-9 * r for q in roots):
                roots.append(r)
    return tuple(sorted(roots))


def _solve_for_param(phi: sympy.Expr, par: sympy.Symbol):
    return sympy.solve(phi, par)


def find_folds(amap: AmplitudeMap, name: str, params: dict, S0: float, seconds: float = 10.0) -> tuple[Fold, ...]:
    """Saddle-nodes of Eq. 41 in parameter ``name`` (extrema of name(A) on Phi = 0)."""
    par = symbol(name)
    free = set().union(*(k.free_symbols for _, k in _power_terms(amap, params)))
    if par not in params and par not in free:
        raise StationaryError(
            f"--fold {name}: '{name}' is not a scalar parameter of R "
            f"(parameters: {', '.join(sorted(s.name for s in params)) or 'none'})"
        )
    others = {k: v for k, v in params.items() if k != par}
    phi = sum((k * A**p for p, k in _power_terms(amap, others)), sympy.Integer(0))
    if par not in phi.free_symbols:
        raise StationaryError(f"--fold {name}: Eq. 41 does not depend on '{name}'")
    sols = bounded_cached("solve", f"{sympy.srepr(phi)}|{sympy.srepr(par)}", _solve_for_param, (phi, par), seconds)
    if not sols:
        raise StationaryError(f"--fold {name}: could not solve Eq. 41 for {name} within {seconds:g} s")
    folds: list[Fold] = []
    for sol in sols:
        f = sympy.lambdify(A, sol, "mpmath")
        df = sympy.lambdify(A, sympy.diff(sol, A), "mpmath")
        grid = np.logspace(-6, 6, 2401)
        with mpmath.workdps(30):
            vals = []
            for a in grid:
                try:
                    v = complex(df(mpmath.mpf(a)))
                    vals.append(v.real if abs(v.imag) < 1e-12 * max(1, abs(v.real)) and math.isfinite(v.real) else math.nan)
                except (ZeroDivisionError, ValueError, OverflowError):
                    vals.append(math.nan)
            vals = np.array(vals)
            for j in range(len(grid) - 1):
                a, b = vals[j], vals[j + 1]
                if math.isnan(a) or math.isnan(b) or np.sign(a) == np.sign(b):
                    continue
                try:
                    root = float(mpmath.findroot(df, (mpmath.mpf(grid[j]), mpmath.mpf(grid[j + 1])), solver="anderson"))
                except (ValueError, ZeroDivisionError):
                    continue
                value = complex(f(mpmath.mpf(root)))
                if abs(value.imag) > 1e-12 or not math.isfinite(value.real):
                    continue
                kind = "minimum" if a < 0 < b else "maximum"
                folds.append(Fold(name, value.real, root, root * S0, kind))
    return tuple(folds)


def stationary(amap: AmplitudeMap, params: dict, S0: float, fold: str | None = None, reference: float | None = None) -> Stationary:
    """Eq. 41: Phi(A) symbolic and numeric, its positive roots, and the fold in ``fold``."""
    sym = sum((t.coefficient * A**t.power for t in amap.power_terms(1, numeric=False)), sympy.Integer(0))
    terms = _power_terms(amap, params)
    numeric = sum((k * A**p for p, k in terms), sympy.Integer(0))
    missing = tuple(sorted({s.name for _, k in terms for s in k.free_symbols}))
    if missing and (fold is None or missing != (fold,)):
        if fold is not None:
            raise StationaryError(needs_values(f"--fold {fold}: Eq. 41", [m for m in missing if m != fold]))
        return Stationary(sym, numeric, (), S0, missing=missing)
    roots = () if missing else positive_roots([(p, float(k)) for p, k in terms])
    folds: tuple[Fold, ...] = ()
    chosen = None
    if fold is not None:  # the fold solves for its parameter: a value is only the reference among several folds
        folds = find_folds(amap, fold, params, S0)
        if reference is None and symbol(fold) in params:
            reference = float(params[symbol(fold)])
        if folds:
            chosen = folds[0] if reference is None else min(folds, key=lambda f: abs(f.value - reference))
    return Stationary(sym, numeric, roots, S0, chosen, folds, missing=missing)
