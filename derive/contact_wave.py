"""The wave of a perturbed contact law and of slowly varying masses (derive/contact.py's energy law is the rest).

Elastic correction P = c d^a (b = 0, :func:`elastic_constants`). At fixed speed nu = A^s the perturbed wave is
g = A (S + eps c A^(a-n) h) + O(eps^2), where h is the even solution of the linearised fixed point of Eq. 4,

    h = Lambda * (n S^(n-1) h + S^a)     (Lambda the hat function; S = Lambda * S^n is the unperturbed wave),

solved on the profile's FFT grid. Its peak is A (S0 + eps c A^(a-n) h(0)) and its energy (same lattice-sum =
integral identity as E_1) E_1 A^(n+1) (1 + eps c A^(a-n) e_h / E_1), e_h = int X' X_h' + int S^n h +
int S^(a+1)/(a+1), X_h' = sum_(k>=0) h'(tau - k). Hence:
  * speed at fixed peak P (A_P = P/S0): nu = A_P^s (1 + sigma eps c A_P^(a-n)), sigma = -s h(0)/S0;
  * entry jump, energy carried across the start of the correction (what is shed is a small wave, energy
    O(eps^(n+1))): P'/P0 = 1 + J eps c A0^(a-n), J = h(0)/S0 - e_h / ((n+1) E_1).

Masses (first order, slowly varying m): E does not depend on m, so A and the strain peak A S0 stay constant and
a bead's velocity peak is V_1 A^(1+s) m^(-1/2), V_1 = max_tau X'(tau) (:func:`taper_law`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import mpmath
import numpy as np
import sympy

from .balance_constants import balance_constants, bead_motion, window
from .balance_law import EPS
from .expansion import exact_exponent
from .integrals import scalar_funcs
from .profile import NPU, check_exponent, exact_profile, get_profile

__all__ = ["ElasticConstants", "TaperLaw", "bead_velocity_factor", "elastic_constants", "first_order_profile",
           "taper_law"]

ELASTIC_NPU = 32  # grid points per unit of the elastic correction's fixed point (a coarsening of the profile's)


# ------------------------------------------------------------------------------ elastic correction
@dataclass(frozen=True)
class ElasticConstants:
    """First-order constants of an elastic correction P = c d^a (module docstring), from the exact profile.

    jump: P'/P0 = 1 + jump eps c A0^(a-n) where the correction starts; speed: nu = A^s (1 + speed eps c A^(a-n))
    at fixed peak A S0; h0: h(0)/S0; energy: e_h/E_1; accuracy: a bound on each constant's error.
    """

    n: float
    a: sympy.Rational
    h0: float
    energy: float
    jump: float
    speed: float
    accuracy: float

    def jump_equation(self) -> sympy.Eq:
        """P'/P0 = 1 + jump eps c A0^(a-n) as a sympy Eq (c and eps symbolic)."""
        c, a0, ratio = sympy.symbols("c A_0 P'/P_0", real=True)
        return sympy.Eq(ratio, 1 + sympy.Float(self.jump, 12) * EPS * c * a0 ** (self.a - exact_exponent(self.n)))

    def speed_equation(self) -> sympy.Eq:
        """nu = A^s (1 + speed eps c A^(a-n)) at fixed peak A S0, as a sympy Eq."""
        c, a, nu = sympy.Symbol("c", real=True), sympy.Symbol("A", positive=True), sympy.Symbol("nu", positive=True)
        n = exact_exponent(self.n)
        return sympy.Eq(nu, a ** ((n - 1) / 2) * (1 + sympy.Float(self.speed, 12) * EPS * c * a ** (self.a - n)))


def _coarse_wave(n: float, stride: int):
    """(tau, S, S', h) of the exact profile on every ``stride``-th node of its periodic FFT grid."""
    prof = exact_profile(n)
    nodes = prof.nodes[::stride]
    m = len(nodes)
    step = prof.h * stride
    tau = prof.tau0 + step * np.arange(m)
    return tau, nodes[:, 0].copy(), nodes[:, 1].copy(), step, prof


def first_order_profile(n: float, a, stride: int = NPU // ELASTIC_NPU) -> tuple[np.ndarray, np.ndarray, float]:
    """(tau, h, grid step): the even solution of h = Lambda * (n S^(n-1) h + S^a) on the coarse FFT grid."""
    tau, S, _, step, _ = _coarse_wave(n, stride)
    m = len(tau)
    k = 2.0 * np.pi * np.fft.rfftfreq(m, d=step)
    hat = np.sinc(k / (2.0 * np.pi)) ** 2
    kernel = np.fft.irfft(hat, n=m)  # the circulant matrix of Lambda * on this grid
    Sp = np.maximum(S, 0.0)
    conv = kernel[(np.arange(m)[:, None] - np.arange(m)[None, :]) % m]
    M = np.eye(m) - conv * (n * Sp ** (n - 1.0))[None, :]
    rhs = np.fft.irfft(hat * np.fft.rfft(Sp ** float(a)), n=m)
    centre = int(np.argmin(np.abs(tau)))
    half = m // 2
    # even functions: h at centre + j equals h at centre - j (indices mod m); unknowns j = 0..half
    expand = np.zeros((m, half + 1))
    for j in range(m):
        expand[j, min((j - centre) % m, (centre - j) % m)] = 1.0
    rows = [(centre + j) % m for j in range(half + 1)]
    x = np.linalg.solve((M @ expand)[rows], rhs[rows])
    return tau, expand @ x, step


def _spectral_derivative(f: np.ndarray, step: float) -> np.ndarray:
    m = len(f)
    k = 2.0 * np.pi * np.fft.rfftfreq(m, d=step)
    return np.fft.irfft(1j * k * np.fft.rfft(f), n=m)


def _bead_sum(f: np.ndarray, per_unit: int) -> np.ndarray:
    """sum_{k >= 0} f(tau - k) on a grid with ``per_unit`` nodes per unit of tau (zero-filled shifts)."""
    out = f.copy()
    for k in range(1, len(f) // per_unit):
        out[k * per_unit:] += f[: len(f) - k * per_unit]
    return out


@lru_cache(maxsize=32)
def elastic_constants(n: float = 1.5, a=None) -> ElasticConstants:
    """The entry jump and speed constants of the elastic correction c d^a (default a = n + 1)."""
    n = check_exponent(n)
    a = exact_exponent(n) + 1 if a is None else sympy.Rational(a)
    if not a > 0:
        from .contact import ContactError  # the contact derivation's error (that module imports this one)

        raise ContactError(f"an elastic correction c*d^a needs a > 0 (a force at zero overlap otherwise), got a = {a}")
    coarse, fine = _elastic_on_grid(n, a, NPU // ELASTIC_NPU * 2), _elastic_on_grid(n, a, NPU // ELASTIC_NPU)
    prof = exact_profile(n)
    # error bound: the change from half the grid (spectral: the finer grid is far better) plus the profile's own
    accuracy = max(abs(x - y) for x, y in zip(coarse, fine)) + prof.accuracy * max(1.0, abs(fine[1]))
    h0, energy = fine
    s = (n - 1.0) / 2.0
    return ElasticConstants(n, a, h0, energy, h0 - energy / (n + 1.0), -s * h0, accuracy)


def _elastic_on_grid(n: float, a: sympy.Rational, stride: int) -> tuple[float, float]:
    """(h(0)/S0, e_h/E_1) from the solve on every ``stride``-th node of the profile's grid."""
    tau, S, dS, step, prof = _coarse_wave(n, stride)
    _, h, _ = first_order_profile(n, a, stride)
    per_unit = NPU // stride
    Sp = np.maximum(S, 0.0)
    dh = _spectral_derivative(h, step)
    e_h = step * float(np.sum(_bead_sum(dS, per_unit) * _bead_sum(dh, per_unit))
                       + np.sum(Sp**n * h) + np.sum(Sp ** (float(a) + 1)) / (float(a) + 1))
    consts = balance_constants(["K1", "V1"], n=n)
    return float(h[int(np.argmin(np.abs(tau)))]) / prof.S0, e_h / (consts["K1"].value + consts["V1"].value)


# ------------------------------------------------------------------------------ masses
@lru_cache(maxsize=16)
def bead_velocity_factor(n: float = 1.5) -> float:
    """V_1 = max_tau X'(tau), X' = sum_(k>=0) S'(tau - k): a bead's velocity peak is V_1 A^(1+s) for unit mass."""
    n = check_exponent(n)
    prof = exact_profile(n)
    L = window(n)
    _, dS, d2S = scalar_funcs(prof)

    dX, d2X = bead_motion(dS, d2S, L)  # X' and X'' of a bead
    grid = np.arange(-L, L, 1.0 / 64)
    speeds = [float(dX(mpmath.mpf(t))) for t in grid]
    t0 = grid[int(np.argmax(speeds))]
    with mpmath.workdps(16):
        top = mpmath.findroot(d2X, mpmath.mpf(t0))
        return float(dX(top))


@dataclass(frozen=True)
class TaperLaw:
    """First-order mass law: strain peak constant, bead velocity peak V_1 (P/S0)^(1+s) m_i^(-1/2)."""

    n: float
    S0: float
    V1: float

    def velocity_peak(self, strain_peak: float, mass: float) -> float:
        """A bead's velocity peak for a wave of strain peak ``strain_peak`` on a bead of mass ``mass``."""
        s = (self.n - 1.0) / 2.0
        return self.V1 * (strain_peak / self.S0) ** (1.0 + s) * mass**-0.5

    def equations(self) -> tuple[sympy.Eq, sympy.Eq]:
        """(P_i = P_0, v_i = V_1 (P_0/S0)^(1+s) m_i^(-1/2)) as sympy Eqs."""
        p_i, p0, v_i, m_i = sympy.symbols("P_i P_0 v_i m_i", positive=True)
        s = (exact_exponent(self.n) - 1) / 2
        return (sympy.Eq(p_i, p0),
                sympy.Eq(v_i, sympy.Float(self.V1, 15) * (p0 / sympy.Float(self.S0, 15)) ** (1 + s) / sympy.sqrt(m_i)))


def taper_law(n: float = 1.5) -> TaperLaw:
    """The first-order taper law for exponent n (module docstring)."""
    n = check_exponent(n)
    return TaperLaw(n, get_profile("exact", n).S0, bead_velocity_factor(n))
