"""Stationary shocks (Eq. 41): roots, their stability as fixed points of the map, continuation.

* roots of Phi(A) = 0 (generated ``stationary``) on a log grid, refined by brentq;
* the fixed point of the chosen map variant near each root (for the 1d variant it is the root
  itself; the paper's map is shifted by its eps-independent drift, erratum 5, docs/errata.rst) and its
  multiplier dA_i/dA_{i-1} from the implicit-function theorem on the generated Jacobian;
* continuation of the roots in a parameter, and the fold (saddle-node) where two roots meet,
  refined by Newton on Phi = dPhi/dA = 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import ModuleType

import numpy as np

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.models.map_iteration import contact_params, step


def _args(module: ModuleType, params: dict) -> tuple:
    """The generated functions' parameter arguments for a uniform chain (scalar parameters)."""
    return contact_params(module, params, 10**6)


def _phi(module, params):
    args = _args(module, params)
    return lambda a: module.stationary(a, *args)[0]


def roots(module: ModuleType, params: dict, lo: float = 1e-8, hi: float = 1e6, points: int = 3000) -> list[float]:
    """Positive roots of Eq. 41 in [lo, hi]: sign changes on a log grid, refined by brentq."""
    phi = _phi(module, params)
    grid = np.geomspace(lo, hi, points)
    # the generated code is numpy code: one call on the whole grid (a constant Phi comes back a scalar)
    vals = np.broadcast_to(np.asarray(phi(grid), dtype=float), grid.shape)
    from scipy.optimize import brentq  # scipy loads only when Eq. 41 is solved

    out = []
    for j in np.nonzero(np.sign(vals[:-1]) * np.sign(vals[1:]) < 0)[0]:
        out.append(brentq(phi, grid[j], grid[j + 1], xtol=1e-15 * grid[j + 1], rtol=1e-15))
    return out


def multiplier(module: ModuleType, a: float, eps: float, params: dict) -> float:
    """dA_i/dA_{i-1} of the map at A_{i-1} = A_i (= A_{i+1}) = a."""
    args = _args(module, params)
    sol, _ = step(module, a, eps, args)
    if sol is None:
        return math.nan
    jac, dprev = module.map_jacobian(a, *sol, eps, *args)
    if module.VARIANT == "1d":
        return -dprev[0] / jac[0][0]
    (j11, j12), (j21, j22) = jac
    det = j11 * j22 - j12 * j21
    return -(dprev[0] * j22 - dprev[1] * j12) / det


def map_fixed_point(module: ModuleType, guess: float, eps: float, params: dict) -> float | None:
    """A with map(A) = A near ``guess`` (the paper's map is shifted from Eq. 41's root)."""
    args = _args(module, params)

    def g(a):
        sol, _ = step(module, a, eps, args)
        return math.nan if sol is None else sol[0] - a

    for width in (0.02, 0.1, 0.3, 0.6):
        lo, hi = guess * (1 - width), guess * (1 + width)
        glo, ghi = g(lo), g(hi)
        if math.isfinite(glo) and math.isfinite(ghi) and glo * ghi < 0:
            from scipy.optimize import brentq

            return brentq(g, lo, hi, xtol=1e-14 * hi)
    return None


def stability(module: ModuleType, root: float, eps: float, params: dict) -> tuple[float | None, float | None, bool | None]:
    """(fixed point of the map near a root of Eq. 41, its multiplier, stable = |multiplier| < 1);
    None where there is no fixed point or no finite multiplier."""
    fp = root if module.VARIANT == "1d" else map_fixed_point(module, root, eps, params)
    if fp is None:
        return None, None, None
    lam = multiplier(module, fp, eps, params)
    if not math.isfinite(lam):
        return fp, None, None
    return fp, float(lam), bool(abs(lam) < 1)


def is_fold(count_before: int, count_after: int) -> bool:
    """Two stationary roots appear or disappear between two parameter values."""
    return abs(count_before - count_after) == 2


@dataclass(frozen=True)
class Continuation:
    param: str
    values: np.ndarray
    branches: list  # per parameter value: list of roots
    folds: list  # (param value, A)


def continue_roots(module: ModuleType, params: dict, name: str, start: float, stop: float, points: int = 121) -> Continuation:
    """Roots of Eq. 41 as ``name`` runs from start to stop; folds refined by Newton."""
    if name not in module.PARAMS:
        raise PulsemapError(f"'{name}' is not a parameter of this map (parameters: {', '.join(module.PARAMS)})")
    values = np.linspace(start, stop, points)
    branches = []
    for p in values:
        branches.append(roots(module, {**params, name: float(p)}))
    folds = []
    for k in range(points - 1):
        if is_fold(len(branches[k]), len(branches[k + 1])):
            pair = branches[k] if len(branches[k]) > len(branches[k + 1]) else branches[k + 1]
            a0 = math.sqrt(pair[0] * pair[1]) if len(pair) >= 2 else pair[0]
            folds.append(refine_fold(module, params, name, 0.5 * (values[k] + values[k + 1]), a0))
    return Continuation(name, values, branches, folds)


def refine_fold(module: ModuleType, params: dict, name: str, p0: float, a0: float) -> tuple[float, float]:
    """Newton on Phi = 0, A dPhi/dA = 0 in (log A, p)."""
    p, x = float(p0), math.log(a0)
    for _ in range(100):
        prm = {**params, name: p}
        args = _args(module, prm)
        a = math.exp(x)
        phi, dphi = module.stationary(a, *args)
        # second equation: a dPhi/dA; derivatives by central differences of the generated code
        h = 1e-6
        _, dphi_p = module.stationary(a * math.exp(h), *args)
        _, dphi_m = module.stationary(a * math.exp(-h), *args)
        g = a * dphi
        g_x = (a * math.exp(h) * dphi_p - a * math.exp(-h) * dphi_m) / (2 * h)
        phi_x = a * dphi
        dp = module.stationary_dparam(a, *args)[name]
        hp = 1e-7 * max(1.0, abs(p))
        args_p = _args(module, {**prm, name: p + hp})
        args_m = _args(module, {**prm, name: p - hp})
        g_p = a * (module.stationary(a, *args_p)[1] - module.stationary(a, *args_m)[1]) / (2 * hp)
        det = phi_x * g_p - dp * g_x
        if det == 0:
            break
        dx = (phi * g_p - dp * g) / det
        dpp = (phi_x * g - g_x * phi) / det
        x -= dx
        p -= dpp
        if abs(dx) < 1e-13 and abs(dpp) < 1e-13 * max(1, abs(p)):
            break
    return p, math.exp(x)
