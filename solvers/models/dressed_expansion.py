"""The dressed coefficients derived by expanding the chain about the exact solitary wave.

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
extrapolated geometrically to cut -> 0 (dressed_derived.py; v converges like the cut itself, a
foundation, whose displaced wake opens its contacts, more slowly: its next term is not analytic,
|x|^(3/2)).
"""

from __future__ import annotations

import math

import numpy as np

from pulsemap.symbolic.profile import NPU, exact_profile
from pulsemap.symbolic.scaling import scaling_exponent


class ExpansionError(ValueError):
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
        self.offsets = NPU * np.arange(1, beads)  # contact j sits NPU * j nodes behind contact 0
        self.coef = _hermite_matrix()
        self.scale = np.array([1.0, self.h, self.h**2])

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        pos = (t + self.centre - self.tau0) / self.h
        J = math.floor(pos)
        r = pos - J
        idx = J - self.offsets
        m = self.nodes.shape[0]
        inside = (idx >= 0) & (idx <= m - 2)
        idx = np.clip(idx, 0, m - 2)
        rows = np.concatenate([self.nodes[idx] * self.scale, self.nodes[idx + 1] * self.scale], axis=1)
        powers = r ** np.arange(6)
        dpowers = np.array([0.0, 1.0, 2 * r, 3 * r**2, 4 * r**3, 5 * r**4]) / self.h
        d0 = np.where(inside, rows @ (powers @ self.coef), 0.0)
        dv = np.where(inside, rows @ (dpowers @ self.coef), 0.0)
        d0 = np.maximum(d0, 0.0)
        x0 = np.zeros(self.beads)
        v0 = np.zeros(self.beads)
        x0[:-1] = np.cumsum(d0[::-1])[::-1]
        v0[:-1] = np.cumsum(dv[::-1])[::-1]
        return d0, x0, v0


def _power(x: np.ndarray, p: int) -> np.ndarray:
    return np.ones_like(x) if p == 0 else x**p


def _derivatives(mono: tuple[int, int], x0: np.ndarray, v0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """d(u^a v^b)/du and d(u^a v^b)/dv on the wave."""
    a, b = mono
    du = a * _power(x0, a - 1) * _power(v0, b) if a else np.zeros_like(x0)
    dv = b * _power(x0, a) * _power(v0, b - 1) if b else np.zeros_like(x0)
    return du, dv


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

    def contact_force(k: np.ndarray, strain: np.ndarray) -> np.ndarray:
        """Bead accelerations from contact forces k_j strain_j (free ends)."""
        f = k * strain
        acc = np.zeros(beads)
        acc[1:] += f
        acc[:-1] -= f
        return acc

    def rhs(t, Y):
        Y = Y.reshape(2 * (M + P), beads)
        d0, x0, v0 = base(t)
        F1 = nn * d0 ** (nn - 1)
        if floor:  # F''(d0) tapered below the cut
            F2 = nn * (nn - 1) * d0**nn / (d0 + floor) ** 2
        else:
            F2 = nn * (nn - 1) * d0 ** (nn - 2)
        out = np.empty_like(Y)
        out[0::2] = Y[1::2]
        eta = [Y[2 * j, :-1] - Y[2 * j, 1:] for j in range(M)]
        for j, (a, b) in enumerate(monomials):
            out[2 * j + 1] = contact_force(F1, eta[j]) + mask * _power(x0, a) * _power(v0, b)
        grads = [_derivatives(m, x0, v0) for m in monomials]
        for q, (j, l) in enumerate(pairs):
            z = Y[2 * (M + q)]
            lin = grads[j][0] * Y[2 * l] + grads[j][1] * Y[2 * l + 1]
            if j != l:
                lin = lin + grads[l][0] * Y[2 * j] + grads[l][1] * Y[2 * j + 1]
            weight = 0.5 if j == l else 1.0
            out[2 * (M + q) + 1] = (contact_force(F1, z[:-1] - z[1:]) + contact_force(weight * F2, eta[j] * eta[l])
                                    + mask * lin)
        return out.ravel()

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
