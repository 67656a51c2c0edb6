"""The solitary-wave profile S(tau) of the uncompressed chain (paper Eqs. 4-5).

Exact profile
    S'' = S(tau-1)_+^n - 2 S(tau)_+^n + S(tau+1)_+^n   (Eq. 4, unit phase shift)
is equivalent to the fixed point S = Lambda * S_+^n, where Lambda(x) = max(0, 1 - |x|) is the
hat function (its Fourier transform is sinc^2(k/2)). We solve it by Petviashvili iteration with
FFT on a periodic grid of spacing h = 1/NPU, wide enough for the super-exponential tails, so
that shifts by +-1 are exact grid shifts. S'' then follows from Eq. 4 on the grid and S' from
the spectrum; between nodes the profile is a quintic Hermite interpolant of (S, S', S'').

Pade form (Eq. 5, n = 3/2 in the paper, any n here)
    S(tau) ~ (q0 + q2 tau^2 + q4 tau^4 + q6 tau^6 + q8 tau^8)^(-2),
with q0 = S(0)^(-1/2) and q2..q8 fitted to the exact profile (erratum 10, docs/errata.rst).

Only numpy (never scipy): derive/ is the symbolic side.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from .errors import PulsemapError
from .sources import PROFILE_KINDS

#: Grid points per unit of tau; shifts by one are exact shifts of NPU nodes.
NPU = 256
#: Supported contact exponents: near 1 the wave is wide and slow to compute (n = 1.01: ~20 s).
N_MIN, N_MAX = 1.01, 20.0
#: Relative size below which the tails count as zero when sizing the domain.
TAIL = 1e-15
#: Profile values below this count as zero inside the iteration: the super-exponential tails
#: otherwise become subnormal floats, on which numpy's power is ~100x slower.
FLUSH = 1e-250


class ProfileError(PulsemapError):
    """Bad input to the profile layer (exponent, profile name)."""


def check_exponent(n: float) -> float:
    """Return n as float, or raise a one-line error if it is not a finite number > 1."""
    if isinstance(n, bool):
        raise ProfileError(f"exponent n must be a number > 1, got {n!r}")
    try:
        value = float(n)
    except (TypeError, ValueError):
        raise ProfileError(f"exponent n must be a number > 1, got {n!r}") from None
    if not math.isfinite(value) or value <= 1.0:
        raise ProfileError(
            f"exponent n must be a finite number > 1 (Hertz: 1.5), got {n!r}"
        )
    if value < N_MIN:
        raise ProfileError(
            f"exponent n = {n!r} is too close to 1: supported {N_MIN:g} <= n <= {N_MAX:g} (the solitary wave "
            "widens like (n - 1)^(-1/2) and its Petviashvili iteration needs ~1/(n - 1) steps; n = 1 is the "
            "linear chain, which has no solitary wave)"
        )
    if value > N_MAX:
        raise ProfileError(f"exponent n = {n!r} is outside the supported range {N_MIN:g} <= n <= {N_MAX:g}")
    return value


def check_profile_kind(kind: str) -> str:
    """Return the profile name, or raise a one-line error naming the known ones."""
    if kind not in PROFILE_KINDS:
        raise ProfileError(
            f"unknown profile {kind!r}: choose one of {', '.join(PROFILE_KINDS)}"
        )
    return kind


@dataclass(frozen=True, eq=False)
class Profile:
    """A solitary-wave profile S(tau) that can be evaluated with S' and S'' at any tau.

    ``accuracy`` bounds |S_repr - S_true| / S(0) for this representation: for the exact profile
    the larger of the Eq. 4 residual and the Petviashvili step; for the Pade form its maximum
    deviation from the exact profile.
    """

    kind: str
    n: float
    S0: float
    accuracy: float
    residual: float
    half_width: float
    tail: float  # |tau| beyond which S < TAIL * S0
    q: tuple[float, ...] = ()  # Pade q0, q2, q4, q6, q8 (pade only)
    iterations: int = 0
    tau0: float = 0.0
    h: float = 1.0 / NPU
    nodes: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)

    # ------------------------------------------------------------------ evaluation
    def S(self, tau: np.ndarray | float) -> np.ndarray:
        """S(tau), vectorised."""
        return self._eval(tau, 0)

    def dS(self, tau: np.ndarray | float) -> np.ndarray:
        """S'(tau), vectorised."""
        return self._eval(tau, 1)

    def d2S(self, tau: np.ndarray | float) -> np.ndarray:
        """S''(tau), vectorised."""
        return self._eval(tau, 2)

    def _eval(self, tau, order: int) -> np.ndarray:
        t = np.asarray(tau, dtype=float)
        if self.kind == "pade":
            return _pade_eval(self.q, t, order)
        return _hermite_eval(self.nodes, self.tau0, self.h, t, order)

    def scalar_evaluator(self):
        """A fast pure-Python ``f(tau, order)`` for scalar tau (exact profile), for quadrature."""
        if self.kind == "pade":
            return lambda t, order: float(self._eval(t, order))
        rows = self.nodes.tolist()
        tau0, h, m = self.tau0, self.h, len(rows)

        def f(t: float, order: int) -> float:
            x = (t - tau0) / h
            if x < 0 or x > m - 1:
                return 0.0
            j = min(int(x), m - 2)
            r = x - j
            f0, d0, c0 = rows[j]
            f1, d1, c1 = rows[j + 1]
            d0, d1, c0, c1 = d0 * h, d1 * h, c0 * h * h, c1 * h * h
            df = f1 - f0
            a3 = 10 * df - 6 * d0 - 4 * d1 - 1.5 * c0 + 0.5 * c1
            a4 = -15 * df + 8 * d0 + 7 * d1 + 1.5 * c0 - c1
            a5 = 6 * df - 3 * (d0 + d1) - 0.5 * c0 + 0.5 * c1
            if order == 0:
                return f0 + r * (d0 + r * (0.5 * c0 + r * (a3 + r * (a4 + r * a5))))
            if order == 1:
                return (d0 + r * (c0 + r * (3 * a3 + r * (4 * a4 + r * 5 * a5)))) / h
            return (c0 + r * (6 * a3 + r * (12 * a4 + r * 20 * a5))) / (h * h)

        return f

    def describe(self) -> str:
        """One line naming the profile and its accuracy."""
        return (
            f"{self.kind} profile, n = {self.n:g}, S(0) = {self.S0:.12g}, "
            f"accuracy {self.accuracy:.1e} (relative to S(0))"
        )


# ---------------------------------------------------------------------- exact profile
_DOT_BLOCK = 8192


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    """Inner product in blocks of 8192: OpenBLAS threads a longer dot, which on a busy machine runs
    up to 1000x slower (n near 1 needs a longer grid); one block is exactly ``np.dot``."""
    return sum(float(np.dot(a[k : k + _DOT_BLOCK], b[k : k + _DOT_BLOCK])) for k in range(0, len(a), _DOT_BLOCK))


def _petviashvili(n: float, half_length: float, tol: float, maxit: int):
    """Petviashvili iteration for S = Lambda * S_+^n on [-half_length, half_length)."""
    m = int(round(2 * half_length * NPU))
    h = 1.0 / NPU
    tau = (np.arange(m) - m // 2) * h
    k = 2.0 * np.pi * np.fft.rfftfreq(m, d=h)
    hat = np.sinc(k / (2.0 * np.pi)) ** 2  # Fourier transform of Lambda
    gamma = n / (n - 1.0)
    s = np.exp(-(tau**2) / 2.0)
    step = np.inf
    for it in range(1, maxit + 1):
        pos = np.maximum(s, 0.0)
        pos[pos < FLUSH] = 0.0
        conv = np.fft.irfft(hat * np.fft.rfft(pos**n), n=m)
        stab = _dot(s, s) / _dot(s, conv)  # Petviashvili stabilising factor
        new = stab**gamma * conv
        step = float(np.max(np.abs(new - s)) / np.max(new))
        s = new
        if step < tol:
            break
    else:
        raise ProfileError(
            f"Petviashvili iteration for n = {n!r} did not converge in {maxit} steps "
            f"(last step {step:.1e})"
        )
    # Enforce the exact symmetry of the even solution (removes FFT round-off asymmetry).
    centre = m // 2
    s[1:] = 0.5 * (s[1:] + s[1:][::-1])
    d1 = np.fft.irfft(1j * k * np.fft.rfft(s), n=m)
    d2_spec = np.fft.irfft(-(k**2) * np.fft.rfft(s), n=m)
    return tau, s, d1, d2_spec, centre, it, step


@lru_cache(maxsize=16)
def exact_profile(n: float = 1.5, tol: float = 1e-15) -> Profile:
    """The exact solitary wave of Eq. 4 for exponent n (Petviashvili + FFT)."""
    n = check_exponent(n)
    half = 16.0
    while True:
        tau, s, d1, d2_spec, centre, its, step = _petviashvili(n, half, tol, 20000)
        s0 = float(s[centre])
        far = np.abs(tau) > half - 3.0
        if np.max(np.abs(s[far])) < 1e-15 * s0 or half >= 512:
            break
        half *= 2.0
    npos = np.maximum(s, 0.0) ** n
    # S'' from Eq. 4 itself: shifts by one unit are shifts of NPU nodes (zero outside).
    pad = np.zeros(NPU)
    ext = np.concatenate([pad, npos, pad])
    d2 = ext[: len(s)] - 2.0 * npos + ext[2 * NPU :]
    inner = np.abs(tau) < half - 2.0
    residual = float(np.max(np.abs(d2_spec - d2)[inner]) / s0)
    nodes = np.stack([s, d1, d2], axis=1)
    above = np.nonzero(s >= TAIL * s0)[0]
    tail = float(max(abs(tau[above[0]]), abs(tau[above[-1]])))
    # half width at half maximum: first node where S < S0/2, refined linearly.
    j = centre + int(np.argmax(s[centre:] < 0.5 * s0))
    frac = (s[j - 1] - 0.5 * s0) / (s[j - 1] - s[j])
    half_width = float(tau[j - 1] + frac / NPU)
    return Profile(
        kind="exact",
        n=n,
        S0=s0,
        accuracy=max(residual, step),
        residual=residual,
        half_width=half_width,
        tail=tail,
        iterations=its,
        tau0=float(tau[0]),
        h=1.0 / NPU,
        nodes=nodes,
    )


def _hermite_eval(nodes: np.ndarray, tau0: float, h: float, t: np.ndarray, order: int):
    """Quintic Hermite interpolation of (S, S', S'') at the nodes; zero outside the grid."""
    m = nodes.shape[0]
    x = (t - tau0) / h
    j = np.clip(np.floor(x).astype(np.int64), 0, m - 2)
    inside = (x >= 0) & (x <= m - 1)
    r = x - j
    f0, d0, c0 = nodes[j, 0], nodes[j, 1] * h, nodes[j, 2] * h * h
    f1, d1, c1 = nodes[j + 1, 0], nodes[j + 1, 1] * h, nodes[j + 1, 2] * h * h
    # Quintic p(r) on [0, 1] with p, p', p'' given at both ends.
    a0, a1, a2 = f0, d0, 0.5 * c0
    a3 = 10 * (f1 - f0) - 6 * d0 - 4 * d1 - 1.5 * c0 + 0.5 * c1
    a4 = -15 * (f1 - f0) + 8 * d0 + 7 * d1 + 1.5 * c0 - c1
    a5 = 6 * (f1 - f0) - 3 * (d0 + d1) - 0.5 * c0 + 0.5 * c1
    if order == 0:
        val = a0 + r * (a1 + r * (a2 + r * (a3 + r * (a4 + r * a5))))
    elif order == 1:
        val = (a1 + r * (2 * a2 + r * (3 * a3 + r * (4 * a4 + r * 5 * a5)))) / h
    else:
        val = (2 * a2 + r * (6 * a3 + r * (12 * a4 + r * 20 * a5))) / (h * h)
    return np.where(inside, val, 0.0)


# ------------------------------------------------------------------------ Pade form
def _pade_eval(q: tuple[float, ...], t: np.ndarray, order: int) -> np.ndarray:
    """(q0 + q2 t^2 + q4 t^4 + q6 t^6 + q8 t^8)^(-2) and its first two derivatives (Eq. 5)."""
    q0, q2, q4, q6, q8 = q
    t2 = t * t
    p = q0 + t2 * (q2 + t2 * (q4 + t2 * (q6 + t2 * q8)))
    if order == 0:
        return p**-2.0
    dp = t * (2 * q2 + t2 * (4 * q4 + t2 * (6 * q6 + t2 * 8 * q8)))
    if order == 1:
        return -2.0 * dp * p**-3.0
    d2p = 2 * q2 + t2 * (12 * q4 + t2 * (30 * q6 + t2 * 56 * q8))
    return 6.0 * dp * dp * p**-4.0 - 2.0 * d2p * p**-3.0


def _fit_pade(exact: Profile) -> tuple[tuple[float, ...], float]:
    """Fit q2..q8 of Eq. 5 to the exact profile; q0 = S(0)^(-1/2). Returns (q, max error)."""
    q0 = exact.S0**-0.5
    t = np.arange(0.0, exact.tail + 1.0, 1.0 / 64)
    s = exact.S(t)
    keep = s > 1e-6 * exact.S0
    tk, sk = t[keep], s[keep]
    # Linear start: S^(-1/2) - q0 = sum q_{2j} t^{2j}, weighted so errors in S count.
    basis = np.stack([tk**2, tk**4, tk**6, tk**8], axis=1)
    w = sk**1.5
    coef, *_ = np.linalg.lstsq(basis * w[:, None], (sk**-0.5 - q0) * w, rcond=None)
    coef = np.maximum(coef, 1e-12)
    full = np.stack([t**2, t**4, t**6, t**8], axis=1)
    weights = np.ones_like(t)
    best = (coef.copy(), np.inf)
    # Levenberg-Marquardt on S_pade - S, with Lawson reweighting towards the minimax fit.
    for _ in range(40):
        lam = 1e-3
        for _ in range(60):
            p = q0 + full @ coef
            r = (p**-2.0 - s) * weights
            jac = (-2.0 * p[:, None] ** -3.0 * full) * weights[:, None]
            jtj = jac.T @ jac
            g = jac.T @ r
            step = np.linalg.solve(jtj + lam * np.diag(np.diag(jtj)), -g)
            trial = coef + step
            if np.all(trial > 0):
                pt = q0 + full @ trial
                rt = (pt**-2.0 - s) * weights
                if rt @ rt < r @ r:
                    coef, lam = trial, lam / 3.0
                    if np.linalg.norm(step) < 1e-14 * np.linalg.norm(coef):
                        break
                    continue
            lam *= 10.0
            if lam > 1e12:
                break
        err = np.abs((q0 + full @ coef) ** -2.0 - s)
        if err.max() < best[1]:
            best = (coef.copy(), float(err.max()))
        weights = weights * (err / err.max() + 1e-3) ** 0.5
        weights /= weights.max()
    coef, _ = best
    q = (q0, *(float(c) for c in coef))
    tt = np.linspace(-exact.tail - 1.0, exact.tail + 1.0, 20001)
    err = float(np.max(np.abs(_pade_eval(q, tt, 0) - exact.S(tt))) / exact.S0)
    return q, err


@lru_cache(maxsize=16)
def pade_profile(n: float = 1.5) -> Profile:
    """The Pade form of Eq. 5 fitted to the exact profile for exponent n."""
    exact = exact_profile(check_exponent(n))
    q, err = _fit_pade(exact)
    p = Profile(
        kind="pade",
        n=exact.n,
        S0=q[0] ** -2.0,
        accuracy=err,
        residual=float("nan"),
        half_width=0.0,
        tail=float("inf"),
        q=q,
    )
    # Half width at half maximum of the Pade form: P(t) = sqrt(2) q0, solved on t^2.
    roots = np.roots([q[4], q[3], q[2], q[1], q[0] - math.sqrt(2.0) * q[0]])
    real = [r.real for r in roots if abs(r.imag) < 1e-12 and r.real > 0]
    hw = math.sqrt(min(real)) if real else float("nan")
    return Profile(
        kind="pade",
        n=p.n,
        S0=p.S0,
        accuracy=err,
        residual=_pade_residual(p, exact),
        half_width=hw,
        tail=float("inf"),
        q=q,
    )


def _pade_residual(pade: Profile, exact: Profile) -> float:
    """Residual of Eq. 4 for the Pade form (it is not an exact solution), relative to S(0)."""
    t = np.linspace(-exact.tail, exact.tail, 4001)
    lhs = pade.d2S(t)
    n = pade.n
    rhs = pade.S(t - 1) ** n - 2 * pade.S(t) ** n + pade.S(t + 1) ** n
    return float(np.max(np.abs(lhs - rhs)) / pade.S0)


def get_profile(kind: str = "exact", n: float = 1.5) -> Profile:
    """The profile named ``kind`` ("exact" or "pade") for exponent n."""
    kind = check_profile_kind(kind)
    n = check_exponent(n)
    return exact_profile(n) if kind == "exact" else pade_profile(n)
