"""The energy balance for any R, polynomial or not, by direct quadrature over the wave.

derive/balance.py expands a polynomial R into monomials and integrates each once. An R that is
not a polynomial in u, v (sin(u), u/(1 + v^2), ...) has no such expansion, but the work of the
on-site force on a bead as the wave of scale A passes is still

    W(A) = eps int R(x, x') x' dt = A int eps R(A X(tau), A^(1+s) X'(tau)) X'(tau) dtau,

X(tau) = sum_{k>=0} S(tau - k) the bead's motion (x = A X, x' = A^(1+s) X', t = tau A^-s). X' vanishes
outside |tau| <= L (derive/balance.window), so W(A) is a quadrature over [-L, L]: Gauss-Legendre,
NODES points per unit interval, with X and X' tabulated once per n (cached) and eps R evaluated
by the generated force module of the DNS (vectorised; no sympy). The wave's energy E_1 = K_1 + V_1
comes from the same nodes. Energy map: E_1 A_i^(n+1) = E_1 A_{i-1}^(n+1) + W_i(A_{i-1}) (bead i);
law: E_1 dB/di = W(A) at bead i + 1/2, B = A^(n+1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from types import ModuleType
from typing import Callable

import numpy as np

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.symbolic.profile import exact_profile
from pulsemap.solvers.models.amplitude_ode import integrate_amplitude_law
from pulsemap.solvers.models.balance_eval import BalanceRun

NODES = 24  # Gauss-Legendre points per unit interval of tau


class EnergyQuadratureError(PulsemapError):
    """The quadrature energy balance cannot be evaluated as asked."""


class PoleOnPath(EnergyQuadratureError):
    """The wave's path (u, v) crosses a pole of R where R diverges: the work of R is not finite."""

    def __init__(self, R: str, term, u_range: tuple[float, float], bead: float):
        self.R, self.term, self.u_range, self.bead = R, term, u_range, bead
        super().__init__(self.at(f"where the wave takes bead {bead:g}"))

    def at(self, place: str) -> str:
        """The one-line message with ``place`` saying where the path meets the pole."""
        lo, hi = self.u_range
        return (f"R = {self.R}: its term {self.term} is infinite {place} (u = {lo:.6g}..{hi:.6g}), so the work of "
                "R on the wave is not finite; R must stay finite for every u, v the chain reaches (move the "
                "singularity out of reach or bound R)")


@dataclass(frozen=True, eq=False)
class WaveTable:
    """Quadrature nodes over |tau| <= L with weights, X, X', and the wave's energy constants."""

    n: float
    s: float
    L: int
    weights: np.ndarray
    X: np.ndarray
    dX: np.ndarray
    K1: float
    V1: float
    S0: float

    @property
    def E1(self) -> float:
        return self.K1 + self.V1


@lru_cache(maxsize=8)
def wave_table(n: float = 1.5, nodes: int = NODES) -> WaveTable:
    """X, X' and weights on the Gauss-Legendre nodes (``nodes`` per unit interval) of [-L, L] for
    exponent n (exact profile)."""
    prof = exact_profile(float(n))
    L = int(math.ceil(prof.tail)) + 1
    g, w = np.polynomial.legendre.leggauss(nodes)
    starts = np.arange(-L, L, dtype=float)
    tau = (starts[:, None] + 0.5 * (g[None, :] + 1.0)).ravel()
    weights = np.tile(0.5 * w, starts.size)
    X = np.zeros_like(tau)
    dX = np.zeros_like(tau)
    for k in range(0, 2 * L + 1):  # S(tau - k) is zero for tau - k < -L
        X += prof.S(tau - k)
        dX += prof.dS(tau - k)
    S = prof.S(tau)
    K1 = float(np.dot(weights, dX**2) / 2)
    V1 = float(np.dot(weights, np.maximum(S, 0.0) ** (n + 1)) / (n + 1))
    return WaveTable(float(n), (float(n) - 1) / 2, L, weights, X, dX, K1, V1, prof.S0)


def work(force: Callable[[np.ndarray, np.ndarray], np.ndarray], A: float, table: WaveTable) -> float:
    """W(A) = A int F(A X, A^(1+s) X') X' dtau, F = eps R at one bead (vectorised over the nodes)."""
    return _work_and_size(force, A, table)[0]


def _work_and_size(force: Callable, A: float, table: WaveTable) -> tuple[float, float]:
    """W(A) and A int |F X'| dtau, the size of W without cancellation (the scale of its quadrature error)."""
    x = A * table.X
    v = A ** (1 + table.s) * table.dX
    with np.errstate(all="ignore"):
        f = np.broadcast_to(np.asarray(force(x, v), dtype=float), x.shape)
        value = A * float(np.dot(table.weights, f * table.dX))
        size = A * float(np.dot(table.weights, np.abs(f * table.dX)))
    if not math.isfinite(value) and (np.isinf(f).any() or not np.isnan(f).any()):  # R's values past float64
        raise OverflowError(f"the work of R on the wave at A = {A:.6g} is past float64's range")
    if not math.isfinite(value):
        raise EnergyQuadratureError(f"the work of R on the wave is not finite at A = {A:.6g}: R is undefined "
                                    "somewhere on the bead's path (x, x')")
    return value, size


def bead_force(module: ModuleType, eps: float, params_at: Callable[[float], tuple]) -> Callable:
    """F(x, v) of the generated force module at a bead position: (x, v, bead) -> eps R."""

    def F(x, v, bead: float):
        return module.force(x, v, bead, eps, *params_at(bead))

    return F


def off_poles(F: Callable, pert, params: tuple, params_at: Callable) -> Callable:
    """``F`` refusing a wave path that crosses a pole of R where R diverges: a term 1/g, g^(-k) or log g
    (tan g: cos g) whose g changes sign between consecutive quadrature nodes (or is 0 at one), with F at
    the float64 points either side of the crossing not finite or above 1e12 times its largest value at
    the nodes. The nodes alone can step over such a pole and give a finite, wrong work; a pole R does
    not feel (u*exp(-1/(u - 1)^2)) passes."""
    import sympy

    from pulsemap.symbolic.expression import singular_terms, symbol

    poles = [(t, sympy.cos(t.args[0]) if isinstance(t, sympy.tan) else (t.base if t.is_Pow else t.args[0]))
             for t in singular_terms(pert.R)]
    if not poles:
        return F
    names = (symbol("u"), symbol("v"), symbol("i"), *(symbol(p) for p in params))
    where = [(term, sympy.lambdify(names, g, "numpy")) for term, g in poles]

    def diverges(x, v, bead: float, g, k: int, scale: float) -> bool:
        """F either side of g's sign change between nodes k and k + 1 (bisected to float64 resolution)."""
        def at(s: float):
            return x[k] + s * (x[k + 1] - x[k]), v[k] + s * (v[k + 1] - v[k])

        def sign(s: float) -> float:
            return float(np.sign(g(*at(s), bead, *params_at(bead))))

        lo, hi, first = 0.0, 1.0, sign(0.0)
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            if mid in (lo, hi):
                break
            lo, hi = (mid, hi) if sign(mid) == first and first != 0.0 else (lo, mid)
        sides = np.array([F(*(np.array([c]) for c in at(s)), bead) for s in (lo, hi)], dtype=float)
        return not (np.all(np.isfinite(sides)) and np.max(np.abs(sides)) <= 1e12 * max(scale, 1e-300))

    def checked(x, v, bead: float):
        out = F(x, v, bead)
        scale = float(np.max(np.abs(out), initial=0.0, where=np.isfinite(out)))
        for term, g in where:
            side = np.sign(np.broadcast_to(g(x, v, bead, *params_at(bead)), np.shape(x)))
            for k in np.flatnonzero((side[:-1] * side[1:] <= 0) & ~((side[:-1] == 0) & (side[1:] == 0))):
                if diverges(x, v, bead, g, int(k), scale):
                    raise PoleOnPath(pert.text, term, (float(x[k]), float(x[k + 1])), bead)
        return out

    return checked


def iterate_energy_map(F: Callable, n: float, seed_A: float, seed_contact: int, last_contact: int,
                       death_fraction: float = 1e-6) -> BalanceRun:
    """E_1 A_i^(n+1) = E_1 A_{i-1}^(n+1) + W_i(A_{i-1}) from A_{seed_contact} = seed_A (bead i's force)."""
    table = wave_table(n)
    Q = n + 1
    contacts = np.arange(seed_contact + 1, last_contact + 1)
    amps: list = []
    a = float(seed_A)
    status, message, ended = "ok", f"reached contact {last_contact}", None
    for i in contacts:
        try:
            base = a**Q + work(lambda x, v: F(x, v, float(i)), a, table) / table.E1
        except OverflowError:  # a power of a Python float past float64
            base = math.inf
        if base == math.inf:
            status, ended = "blow-up", int(i)
            message = (f"the energy map blows up at contact {i}: from A_{i - 1} = {a:.4g} the wave's energy plus "
                       f"bead {i}'s work is past float64's range")
            break
        if not base > 0 or base ** (1 / Q) < death_fraction * seed_A:
            status, ended = "died", int(i)
            message = f"pulse died at contact {i}: the work of bead {i} exceeds what the wave carries"
            break
        a = base ** (1 / Q)
        amps.append(a)
    vals = amps + [None] * (len(contacts) - len(amps))
    return BalanceRun("energy", "map", contacts, vals, [v * table.S0 if v is not None else None for v in vals],
                      status, message, ended, "map (quadrature of R over the wave)", "exact")


def evaluate_energy_law(F: Callable, n: float, A0: float, i0: float, contacts) -> BalanceRun:
    """E_1 dB/di = W(A) at bead i + 1/2, B = A^(n+1), from A(i0) = A0 (LSODA, rtol 1e-11)."""
    if not (np.isfinite(A0) and A0 > 0):
        raise EnergyQuadratureError(f"the initial amplitude must be a finite number > 0, got {A0!r}")
    table = wave_table(n)
    Q = n + 1
    contacts = np.asarray(contacts, dtype=float)

    def rate(i, B):
        return work(lambda x, v: F(x, v, i + 0.5), max(B, 0.0) ** (1 / Q), table) / table.E1

    vals, ended_at, ended = integrate_amplitude_law(rate, A0, Q, i0, contacts, EnergyQuadratureError,
                                                    "the energy law")
    status = ended or "ok"
    msg = f"{status} at contact index {ended_at:.6g}" if ended_at is not None else "ODE solved (LSODA, rtol 1e-11)"
    return BalanceRun("energy", "law", contacts.astype(int), vals, [v * table.S0 if v is not None else None for v in vals],
                      status, msg, ended_at, "quadrature of R over the wave", "exact")


#: Amplitudes at which ``pulsemap derive --model energy`` tabulates the law of a non-polynomial R.
TABLE_AMPLITUDES = tuple(10.0 ** (k / 4) for k in range(-12, 5))

#: A tabulated rate is resolved when its change with twice the nodes is at most this fraction of
#: A int |eps R X'| dtau / E_1 (the rate's size without cancellation); a smooth R changes by ~1e-15.
RATE_TOLERANCE = 1e-6


@dataclass(frozen=True)
class RateTable:
    """The energy law E_1 dB/di = W(A), B = A^(n+1), of one uniform R tabulated at amplitudes A: the rate
    dB/di = W(A)/E_1 and its quadrature error (the change with twice the nodes per unit interval); a rate
    whose error exceeds RATE_TOLERANCE of its size is None (not resolved), never a number."""

    n: float
    nodes: int
    E1: float
    K1: float
    V1: float
    S0: float
    L: int
    A: tuple[float, ...]
    rate: tuple[float | None, ...]
    error: tuple[float, ...]
    size: tuple[float, ...]

    def dlnA_di(self) -> tuple[float | None, ...]:
        """d ln A/di = W(A) / ((n + 1) E_1 A^(n+1)) at each amplitude (None where the rate is not resolved)."""
        return tuple(None if r is None else r / ((self.n + 1) * a ** (self.n + 1)) for a, r in zip(self.A, self.rate))


def rate_table(F: Callable[[np.ndarray, np.ndarray], np.ndarray], n: float,
               amplitudes=TABLE_AMPLITUDES) -> RateTable:
    """The energy law's rate W(A)/E_1 at ``amplitudes`` for the force F(x, v) = eps R (one bead), with
    NODES and 2 NODES points per unit interval: the first is the rate ``run`` uses, the difference its error.
    A path through a pole of R (:func:`off_poles`) is refused, naming the amplitude where the path meets it."""
    table, fine = wave_table(n), wave_table(n, 2 * NODES)
    rate, error, size = [], [], []
    below = None  # the largest amplitude tabulated so far, its path clear of every pole
    for a in amplitudes:
        try:
            w, scale = _work_and_size(F, float(a), table)
            err = abs(w / table.E1 - work(F, float(a), fine) / fine.E1)
        except PoleOnPath as exc:
            meets = _first_pole_amplitude(F, table, below, float(a)) if below is not None else float(a)
            raise EnergyQuadratureError(exc.at(f"where the wave of amplitude A = {meets:.6g} (peak A S(0) = "
                                               f"{meets * table.S0:.6g}) meets it")) from None
        below = float(a)
        rate.append(w / table.E1 if err <= RATE_TOLERANCE * scale / table.E1 else None)
        error.append(err)
        size.append(scale / table.E1)
    return RateTable(float(n), NODES, table.E1, table.K1, table.V1, table.S0, table.L,
                     tuple(float(a) for a in amplitudes), tuple(rate), tuple(error), tuple(size))


def _first_pole_amplitude(F: Callable, table: WaveTable, clear: float, blocked: float) -> float:
    """The amplitude between ``clear`` (path clear of poles) and ``blocked`` (path through one) where the
    wave's path first meets the pole, bisected in log A to 1e-6."""
    while blocked / clear > 1 + 1e-6:
        mid = math.sqrt(clear * blocked)
        try:
            work(F, mid, table)
            clear = mid
        except PoleOnPath:
            blocked = mid
    return blocked
