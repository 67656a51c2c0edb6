"""The strain peaks of a chain of varying masses from a kernel in the local masses, built from the model's own DNS.

    ln P_k = ln P_s + sum_j K_j (ln m_(k+j) - ln m_(s+j)) + c (Q_k - Q_s),   Q_k = sum_(i < k) (ln m_(i+1) - ln m_i)^2

for contact k after the seed contact s, j = J_MIN..J_MAX (beads k + j; contact k joins beads k and k + 1). The first
term is the pulse's first-order response to the masses it is passing, with sum_j K_j = 0: a uniform mass only
rescales time and leaves the strain peak alone (the taper law, derive/contact.py). The second is the second-order
loss to scattering at each mass step, which a random chain accumulates (the mean of ln P falls) and a slow taper
does not. K and c are fitted to the peaks of CALIBRATION chains of random masses 1 + CAL_SD xi (xi uniform of unit
variance, the model's own seeds, never the scene's), contacts ONSET after their entry on; a mass-only chain's peak
ratios do not depend on v0, so one fit serves every v0 at an exponent n. ``residual`` (the fit's RMS in ln P) is
the accuracy it states.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pulsemap.symbolic import cache
from pulsemap.symbolic.errors import PulsemapError

NAMESPACE = "mass-kernel"
VERSION = 1
J_MIN, J_MAX = -4, 5  # beads k + j acting on contact k's peak: the fitted K_j beyond them are below 0.002
ONSET = 5  # contacts after the entry left out of the fit (the pulse adapts to the first masses it meets)
CALIBRATION = (101, 102)  # the calibration chains' seeds
CAL_SD = 0.1  # their masses' standard deviation: a 10 % disorder (a stronger one is beyond the kernel's two orders)
CAL_BEADS, CAL_FIRST, CAL_LAST = 320, 16, 290


class MassKernelError(PulsemapError):
    """A chain the mass kernel cannot take (and why)."""


@dataclass(frozen=True)
class MassKernel:
    """K_j (j = J_MIN..J_MAX), c and the fit's RMS residual in ln P at exponent ``n`` (module docstring)."""

    n: float
    K: tuple[float, ...]
    c: float
    residual: float
    runs: int


def _features(log_m: np.ndarray, contacts: np.ndarray) -> np.ndarray:
    """Per contact k: ln m of beads k + J_MIN .. k + J_MAX (0 beyond the chain: mass 1) and Q_k."""
    pad = np.concatenate([np.zeros(-J_MIN + 1), log_m, np.zeros(J_MAX + 1)])
    window = np.array([[pad[k - 1 + j - J_MIN + 1] for j in range(J_MIN, J_MAX + 1)] for k in contacts])
    q = np.concatenate([[0.0], np.cumsum(np.diff(log_m) ** 2)])  # q[i]: contacts 1..i
    return np.column_stack([window, q[np.minimum(contacts, q.size) - 1]])


def _calibration_masses(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    m = np.ones(CAL_BEADS)
    m[CAL_FIRST - 1:] = 1.0 + CAL_SD * rng.uniform(-np.sqrt(3.0), np.sqrt(3.0), CAL_BEADS - CAL_FIRST + 1)
    return m


def _fit(n: float, rtol: float) -> MassKernel:
    """Least squares over the calibration chains (one intercept each), sum K_j = 0 built in."""
    from pulsemap.solvers.chain.dns import Chain, Integrator, simulate

    rows, targets, chains = [], [], []
    contacts = np.arange(CAL_FIRST + ONSET, CAL_LAST + 1)
    for g, seed in enumerate(CALIBRATION):
        m = _calibration_masses(seed)
        res = simulate(Chain(CAL_BEADS, n, 1.0, masses=m), (CAL_FIRST - 1, CAL_LAST),
                       integrator=Integrator(rtol=rtol), window="auto")
        if not res.alive.all():
            raise MassKernelError(f"a calibration chain of the mass kernel lost its pulse ({res.stop_reason})")
        F = _features(np.log(m), contacts)
        rows.append(np.column_stack([F[:, :-2] - F[:, -2:-1], F[:, -1]]))  # K_last = -sum of the others
        targets.append(np.log(res.peaks[contacts - (CAL_FIRST - 1)]))
        chains.append(np.full(contacts.size, g))
    A = np.vstack(rows)
    group = np.concatenate(chains)
    A = np.column_stack([A] + [(group == g).astype(float) for g in range(len(CALIBRATION))])
    y = np.concatenate(targets)
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    width = J_MAX - J_MIN
    K = tuple(float(k) for k in np.append(coef[:width], -coef[:width].sum()))
    residual = float(np.sqrt(np.mean((A @ coef - y) ** 2)))
    return MassKernel(float(n), K, float(coef[width]), residual, len(CALIBRATION))


def mass_kernel(n: float, rtol: float = 1e-10) -> MassKernel:
    """The mass kernel at exponent ``n``, fitted once (its calibration DNS) and kept in the pulsemap cache."""
    key = (f"mass-kernel|v{VERSION}|n={n!r}|rtol={rtol!r}|J={J_MIN}..{J_MAX}|onset={ONSET}|seeds={CALIBRATION}"
           f"|sd={CAL_SD!r}|chain={CAL_BEADS}:{CAL_FIRST}..{CAL_LAST}|window=auto")
    hit = cache.load(NAMESPACE, key)
    if isinstance(hit, dict) and set(hit) == {"K", "c", "residual", "runs"}:
        return MassKernel(float(n), tuple(float(k) for k in hit["K"]), float(hit["c"]), float(hit["residual"]),
                          int(hit["runs"]))
    kernel = _fit(float(n), float(rtol))
    cache.store(NAMESPACE, key, {"K": list(kernel.K), "c": kernel.c, "residual": kernel.residual, "runs": kernel.runs})
    return kernel


def kernel_peaks(kernel: MassKernel, masses: np.ndarray, seed_peak: float, seed_contact: int,
                 last_contact: int) -> tuple[np.ndarray, np.ndarray]:
    """(contacts seed + 1..last, their strain peaks) of the chain with bead masses ``masses`` (beads 1..N), from the
    peak ``seed_peak`` at ``seed_contact``."""
    if not (np.isfinite(seed_peak) and seed_peak > 0):
        raise MassKernelError(f"the seed peak must be a finite number > 0, got {seed_peak!r}")
    contacts = np.arange(seed_contact, last_contact + 1)
    f = _features(np.log(np.asarray(masses, float)), contacts) @ np.append(kernel.K, kernel.c)
    return contacts[1:], seed_peak * np.exp(f[1:] - f[0])
