"""Direct numerical simulation of the perturbed granular chain, paper Eq. 1.

    x_i'' = (x_{i-1} - x_i)_+^n - (x_i - x_{i+1})_+^n + F_i(x_i, x_i')

with free ends, all beads at rest and bead 1 given velocity v0. The state is interleaved,
y = [x_1, v_1, x_2, v_2, ...], so the Jacobian is banded (lower bandwidth 3, upper 1). The
scipy ``OdeSolver`` classes are driven step by step so that leading-edge peaks (the first local
maximum in time of delta_i = x_i - x_{i+1}) are located on each step's dense output and the run
stops as soon as the last requested contact has peaked or the pulse has died.
"""

from __future__ import annotations

import sys
import time as _time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

import numpy as np
import scipy.integrate as _integrate
from scipy import sparse

# velocity_scale is re-exported: callers import it from solvers.dns
from solvers.peaks import PeakTracker, contact_rate, scan_step, velocity_scale  # noqa: F401

if TYPE_CHECKING:  # pragma: no cover
    from solvers.window import WindowRule

Array = np.ndarray
EXPLICIT_METHODS = ("DOP853", "RK45", "RK23")
IMPLICIT_METHODS = ("Radau", "BDF", "LSODA")
METHODS = ("auto",) + EXPLICIT_METHODS + IMPLICIT_METHODS
STIFFNESS_RATIO = 30.0  # 'auto' goes implicit when stiffness_hint > this x contact rate
ENERGY_BLOWUP = 1e6  # blow-up guard: energy (kinetic + contact) beyond this x initial
STEPS_PER_CONTACT = 2000  # step budget per contact (default_max_steps)


@dataclass(frozen=True)
class OnSiteForce:
    """F(x, v) -> array (N,), eps and the perturbed range already applied (Eq. 1).

    Optional dF/dx and dF/dv (diagonal, arrays (N,)) give implicit methods an analytic
    Jacobian; when either is missing a banded finite-difference Jacobian is used.
    ``stiffness_hint`` is a rate (e.g. max |dF/dv|, sqrt(max |dF/dx|)) used by method='auto'.
    ``restrict(lo, hi)``, optional, returns the same force acting on beads lo..hi-1 only
    (0-based slice; arrays of length hi-lo) for the moving-window DNS; without it the window
    embeds its beads in full-length arrays, which works for any force but costs O(N) per call.
    """

    force: Callable[[Array, Array], Array]
    dforce_dx: Callable[[Array, Array], Array] | None = None
    dforce_dv: Callable[[Array, Array], Array] | None = None
    stiffness_hint: float = 0.0
    restrict: Callable[[int, int], "OnSiteForce"] | None = None

    @property
    def has_jacobian(self) -> bool:
        return self.dforce_dx is not None and self.dforce_dv is not None


@dataclass(frozen=True)
class DNSResult:
    """Leading-edge peaks of the requested contacts (1-based) and how the run went.

    ``mode`` is "full" (all N beads integrated) or "window" (moving window, solvers/window.py);
    ``window_beads`` is the largest number of beads integrated at once, ``window_shifts`` the
    number of solver restarts the window needed and ``window_rule`` its geometry (None: full).
    ``blew_up``: the run was stopped by the blow-up guard (non-finite state or energy beyond
    ENERGY_BLOWUP x initial); the peaks measured before it are kept. ``steps``: accepted steps.
    """

    contacts: Array
    peaks: Array
    peak_times: Array
    alive: Array
    stop_reason: str
    method: str
    rtol: float
    atol: float
    beads: int
    nfev: int
    njev: int
    wall_time_s: float
    energy_drift: float | None
    exponent: float = 0.0
    velocity: float = 0.0
    t_end: float = 0.0
    mode: str = "full"
    window_beads: int = 0
    window_shifts: int = 0
    window_rule: object | None = None
    blew_up: bool = False
    steps: int = 0


# ----------------------------------------------------------------------------- small helpers


def chain_length_for(last_contact: int, margin: int = 10) -> int:
    """Beads needed so the free end cannot disturb the leading edge at ``last_contact``."""
    if last_contact < 1 or margin < 0:
        raise ValueError(f"last_contact must be >= 1 and margin >= 0, got {last_contact}, {margin}")
    return int(last_contact) + 1 + int(margin)


def energy(x: Array, v: Array, exponent: float) -> float:
    """Kinetic plus contact energy of Eq. 1: sum v^2/2 + sum (x_i - x_{i+1})_+^(n+1)/(n+1)."""
    d = np.maximum(np.asarray(x[:-1]) - np.asarray(x[1:]), 0.0)
    return float(0.5 * np.dot(v, v) + np.sum(d ** (exponent + 1.0)) / (exponent + 1.0))


def choose_method(force: OnSiteForce | None, velocity: float, exponent: float) -> str:
    """'DOP853' unless the force's stiffness hint dwarfs the contact rate, then 'LSODA'.

    LSODA (banded analytic Jacobian) was the fastest implicit method in the damped-chain
    benchmarks (eps*mu = 30..3000, rtol 1e-6..1e-10); the explicit and implicit costs cross
    near a stiffness ratio of 30.
    """
    if force is None or force.stiffness_hint <= STIFFNESS_RATIO * contact_rate(velocity, exponent):
        return "DOP853"
    return "LSODA"


def default_t_max(last_contact: int, velocity: float, exponent: float) -> float:
    """Generous time limit: 100x the unperturbed travel time to ``last_contact``."""
    return 100.0 * (last_contact + 5) / contact_rate(velocity, exponent)


def default_max_steps(last_contact: int) -> int:
    """Step budget: 2000 accepted steps per contact (a formed pulse takes ~5-10 at rtol 1e-10)."""
    return STEPS_PER_CONTACT * (int(last_contact) + 10)


def initial_state(beads: int, velocity: float) -> Array:
    """All beads at rest at x = 0, bead 1 with velocity v0 (interleaved state)."""
    y0 = np.zeros(2 * beads)
    y0[1] = velocity
    return y0


# ----------------------------------------------------------------------------- Eq. 1

Boundary = Callable[[float], float]


def power_into(d: Array, exponent: float) -> None:
    """d <- d**n in place for d >= 0 (n = 1.5, 2, 3 by products and sqrt: cheaper than pow)."""
    if exponent == 1.5:
        np.multiply(d, np.sqrt(d), out=d)
    elif exponent == 2.0:
        np.multiply(d, d, out=d)
    elif exponent == 3.0:
        np.multiply(d, d * d, out=d)
    else:
        np.power(d, exponent, out=d)


def make_rhs(
    beads: int,
    exponent: float,
    force: OnSiteForce | None,
    left: Boundary | None = None,
    wall: bool = False,
) -> Callable[[float, Array], Array]:
    """Vectorised right-hand side of Eq. 1 on ``beads`` consecutive beads (interleaved state).

    The whole chain by default (free ends). For a moving window (solvers/window.py):
    ``left`` is the displacement of a prescribed bead before the first one (None: free end);
    ``wall``: the bead after the last one is at rest at x = 0 (False: free end).
    The positions sit in one padded array with the boundary beads (a free end is a copy of
    its neighbour: no compression), so the contact forces are one difference and the
    accelerations another (few numpy calls: call overhead dominates on a small window).
    """
    n = float(exponent)
    on_site = None if force is None else force.force
    xe = np.zeros(beads + 2)  # xe[0]: left boundary bead, xe[-1]: the bead after the last
    d = np.empty(beads + 1)  # d[j]: force of contact j (0: left boundary, beads: wall)
    inner = xe[1:-1]

    def rhs(t: float, y: Array) -> Array:
        out = np.empty(2 * beads)
        out[0::2] = y[1::2]
        inner[:] = y[0::2]
        xe[0] = left(t) if left is not None else xe[1]
        xe[-1] = 0.0 if wall else xe[-2]
        np.subtract(xe[:-1], xe[1:], out=d)
        np.maximum(d, 0.0, out=d)
        power_into(d, n)
        a = out[1::2]
        np.subtract(d[:-1], d[1:], out=a)
        if on_site is not None:
            a += on_site(inner, y[1::2])
        return out

    return rhs


def _band_diagonals(
    beads: int, exponent: float, x: Array, v: Array, force: OnSiteForce | None
) -> tuple[Array, Array, Array, Array]:
    """Diagonals (offsets -3, -1, 0, +1) of the Jacobian of Eq. 1 on the interleaved state."""
    n = float(exponent)
    fp = n * np.maximum(x[:-1] - x[1:], 0.0) ** (n - 1.0)  # d f / d delta per contact
    kdiag = np.zeros(beads)
    kdiag[:-1] -= fp
    kdiag[1:] -= fp
    dfx = np.zeros(beads) if force is None else np.asarray(force.dforce_dx(x, v), float)
    dfv = np.zeros(beads) if force is None else np.asarray(force.dforce_dv(x, v), float)
    m = 2 * beads
    lower3 = np.zeros(m - 3)
    lower3[0::2] = fp  # (v_i, x_{i-1})
    lower1 = np.zeros(m - 1)
    lower1[0::2] = kdiag + dfx  # (v_i, x_i)
    main = np.zeros(m)
    main[1::2] = dfv  # (v_i, v_i)
    upper1 = np.zeros(m - 1)
    upper1[0::2] = 1.0  # (x_i, v_i)
    upper1[1::2] = fp  # (v_i, x_{i+1})
    return lower3, lower1, main, upper1


def make_jacobians(
    beads: int,
    exponent: float,
    force: OnSiteForce | None,
    left: Boundary | None = None,
    wall: bool = False,
) -> tuple[Callable[[float, Array], sparse.csc_matrix], Callable[[float, Array], Array]]:
    """Analytic banded Jacobian of ``make_rhs`` (same arguments; dF/dx, dF/dv needed with a
    force): (sparse for BDF/Radau, packed for LSODA with lband=3, uband=1)."""
    n = float(exponent)

    def diagonals(t: float, y: Array):
        x, v = y[0::2], y[1::2]
        lower3, lower1, main, upper1 = _band_diagonals(beads, n, x, v, force)
        if left is not None:
            d = left(t) - x[0]
            if d > 0.0:
                lower1[0] -= n * d ** (n - 1.0)
        if wall and x[-1] > 0.0:
            lower1[2 * (beads - 1)] -= n * x[-1] ** (n - 1.0)
        return lower3, lower1, main, upper1

    def sparse_jac(t: float, y: Array) -> sparse.csc_matrix:
        return sparse.diags(diagonals(t, y), (-3, -1, 0, 1), shape=(2 * beads, 2 * beads), format="csc")

    def packed_jac(t: float, y: Array) -> Array:
        lower3, lower1, main, upper1 = diagonals(t, y)
        packed = np.zeros((5, 2 * beads))
        packed[0, 1:] = upper1
        packed[1, :] = main
        packed[2, :-1] = lower1
        packed[4, :-3] = lower3
        return packed

    return sparse_jac, packed_jac


def band_pattern(beads: int) -> sparse.csc_matrix:
    """Structural sparsity of the Jacobian: neighbours only (offsets -3, -1, 0, +1)."""
    m = 2 * beads
    ones = [np.ones(m - 3), np.ones(m - 1), np.ones(m), np.ones(m - 1)]
    return sparse.diags(ones, (-3, -1, 0, 1), shape=(m, m), format="csc")


def make_solver(
    method: str,
    beads: int,
    exponent: float,
    force: OnSiteForce | None,
    y0: Array,
    t_max: float,
    rtol: float,
    atol: float,
    *,
    t0: float = 0.0,
    first_step: float | None = None,
    left: Boundary | None = None,
    wall: bool = False,
) -> _integrate.OdeSolver:
    """The scipy OdeSolver for ``method`` with the best Jacobian information available.

    ``left``, ``wall`` as in make_rhs; a moving window restarts the solver at ``t0`` with the
    previous step size as ``first_step``.
    """
    rhs = make_rhs(beads, exponent, force, left, wall)
    cls = getattr(_integrate, method)
    kw = dict(rtol=rtol, atol=atol)
    if first_step is not None:
        kw["first_step"] = min(first_step, t_max - t0)
    if method in EXPLICIT_METHODS:
        return cls(rhs, t0, y0, t_max, **kw)
    analytic = force is None or force.has_jacobian
    sparse_jac, packed_jac = make_jacobians(beads, exponent, force, left, wall)
    if method == "LSODA":
        return cls(rhs, t0, y0, t_max, jac=packed_jac if analytic else None, lband=3, uband=1, **kw)
    if analytic:
        return cls(rhs, t0, y0, t_max, jac=sparse_jac, **kw)
    return cls(rhs, t0, y0, t_max, jac_sparsity=band_pattern(beads), **kw)


def run_scipy(solver: _integrate.OdeSolver, on_step) -> tuple[float, Array, int, float]:
    """Step a scipy OdeSolver until on_step says stop or the solver finishes.

    ``on_step(t_old, y_old, t_new, y_new, dense_factory) -> bool`` is called after every
    accepted step; True stops. Returns (t, y, nfev, last step size); a failed step raises
    RuntimeError (same contract as window.run_fortran).
    """
    while True:
        t_old, y_old = solver.t, solver.y.copy()
        message = solver.step()
        if solver.status == "failed":
            raise RuntimeError(f"integrator failed at t={solver.t:.6g}: {message}")
        if on_step(t_old, y_old, solver.t, solver.y.copy(), solver.dense_output) or solver.status != "running":
            return solver.t, solver.y.copy(), int(solver.nfev), float(solver.step_size or 0.0)


# ----------------------------------------------------------------------------- validation


def validate(
    beads: int,
    exponent: float,
    velocity: float,
    contacts: tuple[int, int],
    method: str,
    rtol: float,
    atol: float,
    peak_fraction: float,
    death_fraction: float,
    t_max: float | None,
    stall_factor: float = 5.0,
    overtake_factor: float = 1.25,
    max_steps: int | None = None,
) -> tuple[int, int]:
    """Check simulate()'s arguments; return the contact range. One-line ValueErrors."""
    if isinstance(beads, bool) or not isinstance(beads, (int, np.integer)) or beads < 2:
        raise ValueError(f"beads must be an integer >= 2, got {beads!r}; use chain_length_for(last_contact)")
    if not np.isfinite(exponent) or exponent <= 1.0:
        raise ValueError(f"exponent must be a finite number > 1 (Hertz: 1.5), got {exponent!r}")
    if not np.isfinite(velocity):
        raise ValueError(f"velocity must be finite, got {velocity!r}")
    if velocity <= 0.0:
        raise ValueError(f"velocity must be > 0 (bead 1 pushes into the chain), got {velocity!r}")
    try:
        first, last = (int(c) for c in contacts)
    except (TypeError, ValueError):
        raise ValueError(f"contacts must be a pair (first, last) of integers, got {contacts!r}") from None
    if (first, last) != tuple(contacts):
        raise ValueError(f"contacts must be integers, got {contacts!r}")
    if not 1 <= first <= last <= beads - 1:
        raise ValueError(
            f"contacts {contacts!r} must satisfy 1 <= first <= last <= beads-1 = {beads - 1}; "
            f"fix the range or use beads=chain_length_for({last})"
        )
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    if not (np.isfinite(rtol) and rtol > 0.0):
        raise ValueError(f"rtol must be a finite number > 0, got {rtol!r}")
    if not (np.isfinite(atol) and atol > 0.0):
        raise ValueError(f"atol must be a finite number > 0, got {atol!r}")
    if not 0.0 < peak_fraction < 1.0:
        raise ValueError(f"peak_fraction must lie in (0, 1), got {peak_fraction!r}")
    if not 0.0 <= death_fraction < 1.0:
        raise ValueError(f"death_fraction must lie in [0, 1), got {death_fraction!r}")
    if t_max is not None and not (np.isfinite(t_max) and t_max > 0.0):
        raise ValueError(f"t_max must be a finite number > 0 or None, got {t_max!r}")
    if not (np.isfinite(stall_factor) and stall_factor > 1.0):
        raise ValueError(f"stall_factor must be a finite number > 1, got {stall_factor!r}")
    if not (np.isfinite(overtake_factor) and overtake_factor > 1.0):
        raise ValueError(f"overtake_factor must be a finite number > 1, got {overtake_factor!r}")
    if max_steps is not None and (isinstance(max_steps, bool) or not isinstance(max_steps, (int, np.integer))
                                  or max_steps < 1):
        raise ValueError(f"max_steps must be an integer >= 1 or None, got {max_steps!r}")
    return first, last


# ----------------------------------------------------------------------------- the run


def simulate(
    beads: int,
    exponent: float,
    velocity: float,
    contacts: tuple[int, int],
    force: OnSiteForce | None = None,
    *,
    method: str = "auto",
    rtol: float = 1e-10,
    atol: float = 1e-12,
    peak_fraction: float = 1e-2,
    death_fraction: float = 1e-3,
    t_max: float | None = None,
    stall_factor: float = 5.0,
    progress: bool = False,
    overtake_factor: float = 1.25,
    window: "int | str | WindowRule | None" = None,
    window_accuracy: float = 1e-8,
    window_engine: str = "auto",
    max_steps: int | None = None,
) -> DNSResult:
    """Integrate Eq. 1 and return the leading-edge peaks of contacts[0]..contacts[1].

    ``window=None`` (default) integrates the whole chain. ``window="auto"`` integrates only a
    moving window of beads around the leading edge (solvers/window.py), sized so that the
    window costs less than ``window_accuracy`` relative peak error; an int gives the window's
    width in beads, a ``WindowRule`` its full geometry. The windowed cost per contact does not
    grow with N. Its ``energy_drift`` counts the energy carried out by dropped beads.
    ``window_engine``: "auto" (Hairer's Fortran DOP853/DOPRI5 for those methods, else the
    scipy OdeSolver), "fortran" or "scipy".

    All contacts 1..last are tracked (each one's acceptance threshold is ``peak_fraction``
    times the previous contact's peak; contact 1 uses the scale v0^(2/(n+1))). The run stops
    when the last contact has peaked, when the pulse dies (a peak below ``death_fraction``
    times the first requested contact's peak), when no new contact peaks within
    ``stall_factor`` times the last inter-peak delay, at ``t_max``, or when the state becomes
    non-finite or the energy grows beyond 1e6 times its initial value. A contact whose first
    maximum exceeds ``overtake_factor`` times the previous contact's no longer carries the
    primary pulse (the wake overtook the front): the run stops there too. ``max_steps``
    (default ``default_max_steps(last)``) bounds the accepted steps, so no run can hang.
    Whatever stops the run, the peaks measured before it are returned (never NaN for a
    contact marked alive).
    """
    first, last = validate(beads, exponent, velocity, contacts, method, rtol, atol,
                           peak_fraction, death_fraction, t_max, stall_factor, overtake_factor, max_steps)
    beads, exponent, velocity = int(beads), float(exponent), float(velocity)
    chosen = choose_method(force, velocity, exponent) if method == "auto" else method
    t_limit = default_t_max(last, velocity, exponent) if t_max is None else float(t_max)
    if window is not None:
        from solvers.window import resolve_rule, simulate_windowed  # window imports this module

        return simulate_windowed(
            beads, exponent, velocity, (first, last), force, rule=resolve_rule(window, window_accuracy),
            method=chosen, rtol=rtol, atol=atol, peak_fraction=peak_fraction,
            death_fraction=death_fraction, t_max=t_limit, stall_factor=stall_factor,
            progress=progress, engine=window_engine, overtake_factor=overtake_factor,
            max_steps=default_max_steps(last) if max_steps is None else int(max_steps))
    y0 = initial_state(beads, velocity)
    e0 = energy(y0[0::2], y0[1::2], exponent)

    wall0 = _time.perf_counter()
    solver = make_solver(chosen, beads, exponent, force, y0, t_limit, rtol, atol)
    track = PeakTracker.start(first, last, velocity, exponent, peak_fraction=peak_fraction,
                              death_fraction=death_fraction, overtake_factor=overtake_factor,
                              stall_factor=stall_factor)
    budget = default_max_steps(last) if max_steps is None else max_steps
    drift = 0.0
    wall_report = wall0

    def on_step(t_old: float, y_old: Array, t_new: float, y_new: Array, dense_factory) -> bool:
        """Bookkeeping after one accepted step (energy every step); True stops the run."""
        nonlocal drift, wall_report
        e = energy(y_new[0::2], y_new[1::2], exponent)
        if track.check_state(t_new, e, e0, ENERGY_BLOWUP):
            return True
        drift = max(drift, abs(e - e0) / e0)
        track.record(scan_step(y_old, y_new, t_old, t_new, dense_factory, track.next_contact,
                               last, track.threshold, peak_fraction))
        if track.check_progress(t_new, t_limit, budget):
            return True
        if progress and _time.perf_counter() - wall_report > 2.0:
            wall_report = _time.perf_counter()
            print(f"[dns] t={t_new:.4g} contact {track.next_contact - 1}/{last} nfev={solver.nfev}",
                  file=sys.stderr)
        return False

    try:
        run_scipy(solver, on_step)
    except RuntimeError as err:
        track.reason = str(err)
    track.reason = track.reason or f"t_max reached (t={solver.t:.6g}, next contact {track.next_contact})"

    wall = _time.perf_counter() - wall0
    contacts_out, peaks, times, alive = track.outcome()
    return DNSResult(
        contacts=contacts_out,
        peaks=peaks,
        peak_times=times,
        alive=alive,
        stop_reason=track.reason,
        method=chosen,
        rtol=float(rtol),
        atol=float(atol),
        beads=beads,
        nfev=int(solver.nfev),
        njev=int(getattr(solver, "njev", 0)),
        wall_time_s=wall,
        energy_drift=drift if force is None else None,
        exponent=exponent,
        velocity=velocity,
        t_end=float(solver.t),
        window_beads=beads,
        blew_up=track.blew_up,
        steps=track.steps,
    )
