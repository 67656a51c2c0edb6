"""The strain peaks of a chain of varying masses from a kernel in the local masses, built from the model's own DNS.

    ln P_k = ln P_s + sum_j K_j (ln m_(k+j) - ln m_(s+j)) + c (Q_k - Q_s),   Q_k = sum_(i < k) (ln m_(i+1) - ln m_i)^2
             + a_1 (G_k - G_s) + a_2 (R_k - R_s) + a_3 (G'_k - G'_s)

for contact k after the seed contact s, j = J_MIN..J_MAX (beads k + j; contact k joins beads k and k + 1). The first
term is the pulse's first-order response to the masses it is passing, with sum_j K_j = 0: a uniform mass only
rescales time and leaves the strain peak alone (the taper law, derive/contact.py). The second is the second-order
loss to scattering at each mass step, which a random chain accumulates (the mean of ln P falls) and a slow taper
does not. K and c are fitted to the peaks of CALIBRATION chains of random masses 1 + CAL_SD xi (xi uniform of unit
variance, the model's own seeds, never the scene's), contacts ONSET after their entry on; a mass-only chain's peak
ratios do not depend on v0, so one fit serves every v0 at an exponent n. ``residual`` (the fit's RMS in ln P) is
the accuracy it states.

The second line is the slow part of the masses, which the random chains barely sample: G_k, the gradient of ln m
averaged over the 2 SMOOTH_HALF_WIDTH + 1 mass steps centred on contact k; R_k = sum_(i < k) G_i^2, the adiabatic
loss of a smooth taper (second order in the gradient); G'_k, the centred difference of G (the taper's curvature). On a
smooth taper the strain peak shifts in proportion to G_k (first order in the gradient, a little more than the random
kernel's sum_j j K_j gives) and falls in proportion to R_k (docs/contact.rst). a_1..a_3 are fitted, after K and c, to the residuals of
SMOOTH_CALIBRATION chains (linear and exponential tapers of the model's own slopes); on random chains G, R and G'
are small, and the kernel's random-chain accuracy moves little.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pulsemap.symbolic import cache
from pulsemap.symbolic.errors import PulsemapError

NAMESPACE = "mass-kernel"
VERSION = 2
J_MIN, J_MAX = -4, 5  # beads k + j acting on contact k's peak: the fitted K_j beyond them are below 0.002
ONSET = 5  # contacts after the entry left out of the fit (the pulse adapts to the first masses it meets)
CALIBRATION = (101, 102)  # the calibration chains' seeds
CAL_SD = 0.1  # their masses' standard deviation: a 10 % disorder (a stronger one is beyond the kernel's two orders)
CAL_BEADS, CAL_FIRST, CAL_LAST = 320, 16, 290
#: The slow part's calibration chains: (form, rate) with m_i = 1 + rate (i - CAL_FIRST) ("linear") or
#: exp(rate (i - CAL_FIRST)) ("exponential") from bead CAL_FIRST; two forms, so the gradient and its curvature separate.
SMOOTH_CALIBRATION = (("linear", 0.004), ("linear", -0.0025), ("exponential", 0.004), ("exponential", -0.004))
#: G_k averages 2 x this + 1 mass steps: 11 is wide enough that random masses leave G small (narrower windows let
#: the random chains' error grow, docs/contact.rst) and narrow enough for a taper's entry.
SMOOTH_HALF_WIDTH = 5


class MassKernelError(PulsemapError):
    """A chain the mass kernel cannot take (and why)."""


@dataclass(frozen=True)
class MassKernel:
    """K_j (j = J_MIN..J_MAX), c, the slow part's a_1..a_3, the fit's RMS residual in ln P on its random chains
    (``residual``) and on its smooth ones (``smooth_residual``) at exponent ``n`` (module docstring)."""

    n: float
    K: tuple[float, ...]
    c: float
    residual: float
    runs: int
    a: tuple[float, float, float] = (0.0, 0.0, 0.0)
    smooth_residual: float = 0.0


def _features(log_m: np.ndarray, contacts: np.ndarray) -> np.ndarray:
    """Per contact k: ln m of beads k + J_MIN .. k + J_MAX (0 beyond the chain: mass 1) and Q_k."""
    pad = np.concatenate([np.zeros(-J_MIN + 1), log_m, np.zeros(J_MAX + 1)])
    window = np.array([[pad[k - 1 + j - J_MIN + 1] for j in range(J_MIN, J_MAX + 1)] for k in contacts])
    q = np.concatenate([[0.0], np.cumsum(np.diff(log_m) ** 2)])  # q[i]: contacts 1..i
    return np.column_stack([window, q[np.minimum(contacts, q.size) - 1]])


def _smooth_features(log_m: np.ndarray, contacts: np.ndarray) -> np.ndarray:
    """Per contact k: G_k, R_k and G'_k of the module docstring (past the chain's ends the end steps continue)."""
    h = SMOOTH_HALF_WIDTH
    steps = np.pad(np.diff(log_m), h + 1, mode="edge")  # steps[h + 1 + i]: ln m of bead i + 2 minus bead i + 1
    G = np.convolve(steps, np.full(2 * h + 1, 1.0 / (2 * h + 1)), mode="valid")[1:-1]  # G[k - 1]: contact k
    R = np.concatenate([[0.0], np.cumsum(G**2)])  # R[k - 1]: contacts 1..k-1
    slope = np.gradient(G)
    at = np.minimum(contacts, G.size) - 1
    return np.column_stack([G[at], R[at], slope[at]])


def _smooth_masses(form: str, rate: float) -> np.ndarray:
    i = np.arange(CAL_BEADS - CAL_FIRST + 1, dtype=float)
    m = np.ones(CAL_BEADS)
    m[CAL_FIRST - 1:] = 1.0 + rate * i if form == "linear" else np.exp(rate * i)
    return m


def _calibration_masses(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    m = np.ones(CAL_BEADS)
    m[CAL_FIRST - 1:] = 1.0 + CAL_SD * rng.uniform(-np.sqrt(3.0), np.sqrt(3.0), CAL_BEADS - CAL_FIRST + 1)
    return m


def _fit(n: float, rtol: float) -> MassKernel:
    """Least squares over the random calibration chains (one intercept each), sum K_j = 0 built in; then a_1..a_3
    over what K and c leave of the smooth chains' peaks, every term taken from the seed contact as kernel_peaks does."""
    from pulsemap.solvers.chain.dns import Chain, Integrator, simulate

    def peaks(m: np.ndarray) -> np.ndarray:
        res = simulate(Chain(CAL_BEADS, n, 1.0, masses=m), (CAL_FIRST - 1, CAL_LAST),
                       integrator=Integrator(rtol=rtol), window="auto")
        if not res.alive.all():
            raise MassKernelError(f"a calibration chain of the mass kernel lost its pulse ({res.stop_reason})")
        return res.peaks

    rows, targets, chains = [], [], []
    contacts = np.arange(CAL_FIRST + ONSET, CAL_LAST + 1)
    for g, seed in enumerate(CALIBRATION):
        m = _calibration_masses(seed)
        P = peaks(m)
        F = _features(np.log(m), contacts)
        rows.append(np.column_stack([F[:, :-2] - F[:, -2:-1], F[:, -1]]))  # K_last = -sum of the others
        targets.append(np.log(P[contacts - (CAL_FIRST - 1)]))
        chains.append(np.full(contacts.size, g))
    A = np.vstack(rows)
    group = np.concatenate(chains)
    A = np.column_stack([A] + [(group == g).astype(float) for g in range(len(CALIBRATION))])
    y = np.concatenate(targets)
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    width = J_MAX - J_MIN
    K = tuple(float(k) for k in np.append(coef[:width], -coef[:width].sum()))
    residual = float(np.sqrt(np.mean((A @ coef - y) ** 2)))
    rows, targets = [], []
    seeded = np.arange(CAL_FIRST - 1, CAL_LAST + 1)  # the seed contact first: every term is taken from it
    for form, rate in SMOOTH_CALIBRATION:
        m = _smooth_masses(form, rate)
        P = peaks(m)
        fast = _features(np.log(m), seeded) @ np.append(K, coef[width])
        slow = _smooth_features(np.log(m), seeded)
        rows.append(slow[1:] - slow[0])
        targets.append(np.log(P[1:] / P[0]) - (fast[1:] - fast[0]))
    a, *_ = np.linalg.lstsq(np.vstack(rows), np.concatenate(targets), rcond=None)
    smooth_residual = float(np.sqrt(np.mean((np.vstack(rows) @ a - np.concatenate(targets)) ** 2)))
    return MassKernel(float(n), K, float(coef[width]), residual, len(CALIBRATION) + len(SMOOTH_CALIBRATION),
                      tuple(float(x) for x in a), smooth_residual)


def mass_kernel(n: float, rtol: float = 1e-10) -> MassKernel:
    """The mass kernel at exponent ``n``, fitted once (its calibration DNS) and kept in the pulsemap cache."""
    key = (f"mass-kernel|v{VERSION}|n={n!r}|rtol={rtol!r}|J={J_MIN}..{J_MAX}|onset={ONSET}|seeds={CALIBRATION}"
           f"|sd={CAL_SD!r}|chain={CAL_BEADS}:{CAL_FIRST}..{CAL_LAST}|window=auto"
           f"|smooth={SMOOTH_CALIBRATION}|half_width={SMOOTH_HALF_WIDTH}")
    fields = {"K", "c", "residual", "runs", "a", "smooth_residual"}
    hit = cache.load(NAMESPACE, key)
    if isinstance(hit, dict) and set(hit) == fields:
        return MassKernel(float(n), tuple(float(k) for k in hit["K"]), float(hit["c"]), float(hit["residual"]),
                          int(hit["runs"]), tuple(float(x) for x in hit["a"]), float(hit["smooth_residual"]))
    kernel = _fit(float(n), float(rtol))
    cache.store(NAMESPACE, key, {"K": list(kernel.K), "c": kernel.c, "residual": kernel.residual, "runs": kernel.runs,
                                 "a": list(kernel.a), "smooth_residual": kernel.smooth_residual})
    return kernel


def kernel_peaks(kernel: MassKernel, masses: np.ndarray, seed_peak: float, seed_contact: int,
                 last_contact: int) -> tuple[np.ndarray, np.ndarray]:
    """(contacts seed + 1..last, their strain peaks) of the chain with bead masses ``masses`` (beads 1..N), from the
    peak ``seed_peak`` at ``seed_contact``."""
    if not (np.isfinite(seed_peak) and seed_peak > 0):
        raise MassKernelError(f"the seed peak must be a finite number > 0, got {seed_peak!r}")
    contacts = np.arange(seed_contact, last_contact + 1)
    log_m = np.log(np.asarray(masses, float))
    f = _features(log_m, contacts) @ np.append(kernel.K, kernel.c) + _smooth_features(log_m, contacts) @ np.asarray(kernel.a)
    return contacts[1:], seed_peak * np.exp(f[1:] - f[0])


def bead_velocity_peaks(n: float, masses: np.ndarray, seed_peak: float, contacts: np.ndarray,
                        peaks: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(beads, velocity peaks) from kernel_peaks' strain peaks (``contacts`` seed + 1..last, ``peaks``): bead b between
    contacts b - 1 and b moves with the taper law's V_1 (P/S0)^(1+s) m_b^(-1/2) (derive/contact_wave.py), P the
    geometric mean of those two contacts' peaks (the seed's for the first bead)."""
    from pulsemap.symbolic.contact_wave import taper_law

    law = taper_law(float(n))
    strain = np.sqrt(np.concatenate([[seed_peak], peaks[:-1]]) * peaks)
    m = np.asarray(masses, float)[contacts - 1]  # bead b = contact b's left bead (1-based)
    return contacts.copy(), np.array([law.velocity_peak(float(p), float(mb)) for p, mb in zip(strain, m)])
