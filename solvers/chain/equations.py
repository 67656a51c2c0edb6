"""The equations of motion shared by every DNS engine, paper Eq. 1.

    x_i'' = (x_{i-1} - x_i)_+^n - (x_i - x_{i+1})_+^n + F_i(x_i, x_i')

The on-site force and result types, energy, initial state, right-hand side, banded Jacobian
and the scipy solver factory. Both the full-chain front end (dns.py) and the moving window
(window.py) import this module; neither imports the other's internals.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

import numpy as np

if TYPE_CHECKING:  # scipy loads only when a scipy engine runs (~0.3 s per process otherwise)
    import scipy.integrate as _integrate
    from scipy import sparse

from pulsemap.symbolic.errors import PulsemapError
# velocity_scale is re-exported: callers import it from pulsemap.solvers.chain.dns
from pulsemap.solvers.chain import methods
from pulsemap.solvers.chain.errors import DNSInputError
from pulsemap.solvers.chain.front import pulse_speed
from pulsemap.solvers.chain.peaks import PeakTracker, contact_rate, scan_step, velocity_scale  # noqa: F401

Array = np.ndarray
EXPLICIT_METHODS = methods.names(scipy=True, implicit=False)  # scipy's explicit OdeSolvers (chain/methods.py)
IMPLICIT_METHODS = methods.names(scipy=True, implicit=True)
METHODS = methods.selectable()
ENGINES = ("compiled", "scipy")
STIFFNESS_RATIO = 30.0  # 'auto' goes implicit when stiffness_hint > this x contact rate
#: atol of a run through a ramp is at most this x its half-width: a velocity step wider than the ramp hops across
#: it and chatters (Coulomb friction on Rodas4 at atol 1e-8 spent its step budget; at 1e-10 it ran, docs/dns.rst).
RAMP_ATOL = 0.1
ENERGY_BLOWUP = 1e6  # blow-up guard: energy (kinetic + contact) beyond this x initial
STEPS_PER_CONTACT = 2000  # step budget per contact at rtol >= BUDGET_RTOL (default_max_steps)
#: Below this rtol the budget per contact grows as (BUDGET_RTOL/rtol)^(1/4), as the steps of Rodas4 (order 4, the
#: lowest-order kernel) do on Coulomb friction's stick-slip, the most steps per contact measured (docs/dns.rst).
BUDGET_RTOL = 1e-10


class ForceNotFinite(PulsemapError, ArithmeticError):
    """The on-site force F_i = eps_i R_i of Eq. 1 (or its slope ``what``) is not finite at bead ``bead``
    (1-based; None: not located) at displacement ``x`` and velocity ``v``, at time ``t`` (None: not known
    where it was found; the engine adds it). ``state``: the compiled engine's (lo, y, f, h) of the failed
    step, for dns.simulate to locate the bead."""

    def __init__(self, bead: int | None, x: float, v: float, value: float, what: str = "force",
                 t: float | None = None, state: tuple | None = None) -> None:
        self.bead, self.x, self.v, self.value, self.what, self.t, self.state = bead, x, v, value, what, t, state
        where = f"bead {bead} (u = {x:.6g}, v = {v:.6g})" if bead is not None else "a bead of the window"
        when = f" at t = {t:.6g}" if t is not None else ""
        super().__init__(f"the on-site {what} is {value} at {where}{when}")

    def at(self, t: float) -> "ForceNotFinite":
        """The same failure at time ``t`` (unchanged if it has a time)."""
        return self if self.t is not None else ForceNotFinite(self.bead, self.x, self.v, self.value, self.what, t)


class IntegratorFailed(RuntimeError):
    """The integrator's step size fell below the spacing of floats (the message says when); ``y``: the
    last state it reached, interleaved (x_1, v_1, x_2, ...), for largest_force to look at."""

    def __init__(self, message: str, y: Array) -> None:
        super().__init__(message)
        self.y = y


def largest_force(force: "OnSiteForce | None", y: Array, lo: int = 0) -> str:
    """Where the on-site force F_i = eps_i R_i is largest in magnitude on state ``y`` (interleaved, beads
    lo+1..), as '; the on-site force is largest at bead i (u = .., v = ..): |eps R| = ..', or '' (no force,
    none finite). A failed step size with a finite force points there: an R that grows without bound."""
    if force is None or np.size(y) < 2:
        return ""
    x, v = np.asarray(y[0::2], float), np.asarray(y[1::2], float)
    try:
        with np.errstate(all="ignore"):
            size = np.abs(np.broadcast_to(force.force(x, v), x.shape))
    except ArithmeticError:  # non-finite there: the engines' own ForceNotFinite names it
        return ""
    size = np.where(np.isfinite(size), size, -1.0)
    j = int(np.argmax(size))
    if size[j] < 0:
        return ""
    return f"; the on-site force is largest at bead {lo + j + 1} (u = {x[j]:.6g}, v = {v[j]:.6g}): |eps R| = {size[j]:.3g}"


def check_finite(values: Array, x: Array, v: Array, lo: int, what: str = "force") -> None:
    """ForceNotFinite at the first bead where ``values`` (over beads lo+1.. of x, v) is not finite at a
    finite state (a non-finite stage state comes from a huge force before it: the integrator rejects
    the step and the smaller one meets the culprit)."""
    bad = ~np.isfinite(np.broadcast_to(values, np.shape(x))) & np.isfinite(x) & np.isfinite(v)
    if bad.any():
        j = int(np.flatnonzero(bad)[0])
        raise ForceNotFinite(lo + j + 1, float(x[j]), float(v[j]), float(np.broadcast_to(values, np.shape(x))[j]), what)


@dataclass(frozen=True)
class OnSiteForce:
    """F(x, v) -> array (N,), eps and the perturbed range already applied (Eq. 1).

    Optional dF/dx and dF/dv (diagonal, arrays (N,)) give implicit methods an analytic
    Jacobian; when either is missing a banded finite-difference Jacobian is used.
    ``stiffness_hint`` is a rate (e.g. max |dF/dv|, sqrt(max |dF/dx|)) used by method='auto'.
    ``restrict(lo, hi)``, optional, returns the same force acting on beads lo..hi-1 only
    (0-based slice; arrays of length hi-lo) for the moving-window DNS; without it the window
    embeds its beads in full-length arrays, which works for any force but costs O(N) per call.
    ``monomials``: the same force as a table for the compiled engine (polynomial R); else ``jit``,
    called only when the compiled engine runs, returns it as a generated numba force or a string
    saying why there is none (a Python callable: the scipy engine runs).
    """

    force: Callable[[Array, Array], Array]
    dforce_dx: Callable[[Array, Array], Array] | None = None
    dforce_dv: Callable[[Array, Array], Array] | None = None
    stiffness_hint: float = 0.0
    restrict: Callable[[int, int], "OnSiteForce"] | None = None
    monomials: object | None = None  # chain.force_table.MonomialTable: the same force as data (compiled engine)
    jit: Callable[[], object] | None = None  # builds chain.force_table.JitForce (numba R) or says why not
    ramp: float = 0.0  # half-width of the ramp R's sign and Heaviside run as (derive/codegen_force.py; 0: none)

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

    Front diagnostics (solvers/chain/front.py), per requested contact at its peak time, NaN where
    it did not peak: ``pulse_energy`` (kinetic + contact energy of the beads within 8 of the
    contact), ``total_energy`` (of the whole chain; a moving window adds the energy its dropped
    beads carried when dropped, exact only without R: with R a windowed run leaves it None); ``energy_initial`` = v0^2/2; ``snapshots``: strains around the
    chosen contacts (front.Snapshot). An engine that does not record them leaves the defaults.
    ``speed`` (a property): contacts per unit time from the peak times.
    ``engine``: "compiled" (chain/compiled.py) or "scipy"; ``engine_reason``: why that engine ran.
    ``compile_s``: seconds spent compiling the kernel or loading it from numba's cache (the first run
    of a kernel in a process; 0.0 otherwise and on the scipy engine), not counted in ``wall_time_s``;
    ``build_s``: the part of it spent building the ahead-of-time kernel (its first use on this machine).
    ``velocity_peaks``: with masses, on the compiled engine, the first maximum in time of each bead's
    velocity, beads 1..last + 1 (NaN where none was seen); None otherwise.
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
    energy_initial: float = 0.0
    pulse_energy: Array | None = None
    total_energy: Array | None = None
    snapshots: tuple = ()
    engine: str = "scipy"
    engine_reason: str = ""
    compile_s: float = 0.0
    build_s: float = 0.0
    velocity_peaks: Array | None = None

    @property
    def speed(self) -> Array:
        """Pulse speed at each requested contact (contacts per unit time, front.pulse_speed)."""
        return pulse_speed(self.peak_times)

    @classmethod
    def tracked(cls, track: PeakTracker, front, **fields) -> "DNSResult":
        """The result of a scipy-engine run: peaks, stop reason, blow-up flag and steps from its
        PeakTracker, energies and snapshots from its front.FrontRecorder (None: not recorded),
        everything else from ``fields``."""
        contacts, peaks, times, alive = track.outcome()
        recorded = {} if front is None else {"pulse_energy": front.pulse, "total_energy": front.total,
                                             "snapshots": tuple(front.snapshots)}
        return cls(contacts=contacts, peaks=peaks, peak_times=times, alive=alive, stop_reason=track.reason,
                   blew_up=track.blew_up, steps=track.steps, **recorded, **fields)


# ----------------------------------------------------------------------------- small helpers


def chain_length_for(last_contact: int, margin: int = 10) -> int:
    """Beads needed so the free end cannot disturb the leading edge at ``last_contact``."""
    if last_contact < 1 or margin < 0:
        raise DNSInputError(f"last_contact must be >= 1 and margin >= 0, got {last_contact}, {margin}")
    return int(last_contact) + 1 + int(margin)


def energy(x: Array, v: Array, exponent: float, masses: Array | None = None) -> float:
    """Kinetic plus contact energy of Eq. 1: sum m v^2/2 + sum (x_i - x_{i+1})_+^(n+1)/(n+1) (m = 1 by default)."""
    d = np.maximum(np.asarray(x[:-1]) - np.asarray(x[1:]), 0.0)
    kinetic = 0.5 * np.dot(v, v) if masses is None else 0.5 * np.dot(masses * v, v)
    return float(kinetic + np.sum(d ** (exponent + 1.0)) / (exponent + 1.0))


def choose_method(force: OnSiteForce | None, velocity: float, exponent: float) -> str:
    """The scipy engine's 'auto' (chain/methods.py roles): DOP853 unless the force's stiffness hint dwarfs the
    contact rate, then LSODA, or BDF for a force with a ramp (a non-smooth R).

    LSODA (banded analytic Jacobian) was the fastest implicit method in the damped-chain
    benchmarks (eps*mu = 30..3000, rtol 1e-6..1e-10); the explicit and implicit costs cross
    near a stiffness ratio of 30. Through a ramp's corners (Coulomb friction's stick phases) LSODA's
    switching goes astray at loose rtol (1e-2 off at rtol 1e-8, its step budget spent at 1e-9); BDF
    is 2-3x slower there and converges with rtol (docs/dns.rst).
    """
    if force is None or force.stiffness_hint <= STIFFNESS_RATIO * contact_rate(velocity, exponent):
        return methods.auto_pick("scipy explicit")
    ramp = getattr(force, "ramp", 0.0)  # force: anything with a stiffness hint (plan.plan)
    return methods.auto_pick("scipy ramp" if ramp else "scipy stiff")


def ramp_atol(force: OnSiteForce | None, atol: float) -> float:
    """The atol a run takes: ``atol``, at most RAMP_ATOL x the force's ramp half-width (a non-smooth R)."""
    return min(float(atol), RAMP_ATOL * force.ramp) if force is not None and force.ramp else float(atol)


def default_t_max(last_contact: int, velocity: float, exponent: float) -> float:
    """Generous time limit: 100x the unperturbed travel time to ``last_contact``."""
    return 100.0 * (last_contact + 5) / contact_rate(velocity, exponent)


def default_max_steps(last_contact: int, rtol: float = BUDGET_RTOL) -> int:
    """Step budget, scaled with the run's length: STEPS_PER_CONTACT accepted steps per contact up to
    ``last_contact``, times (BUDGET_RTOL/rtol)^(1/4) for a tighter rtol (a run takes ~50-250 per contact
    at rtol 1e-10, Coulomb friction's stick phases the most)."""
    per_contact = STEPS_PER_CONTACT * max(1.0, (BUDGET_RTOL / float(rtol)) ** 0.25)
    return int(math.ceil(per_contact * (int(last_contact) + 10)))


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
    terms: "tuple | None" = None,
    lo: int = 0,
) -> Callable[[float, Array], Array]:
    """Vectorised right-hand side of Eq. 1 on ``beads`` consecutive beads (interleaved state).

    The whole chain by default (free ends). For a moving window (solvers/window.py):
    ``left`` is the displacement of a prescribed bead before the first one (None: free end);
    ``wall``: the bead after the last one is at rest at x = 0 (False: free end).
    The positions sit in one padded array with the boundary beads (a free end is a copy of
    its neighbour: no compression), so the contact forces are one difference and the
    accelerations another (few numpy calls: call overhead dominates on a small window).
    ``terms``: (contact, masses) of these beads (a contact_force.ContactTable or None, their masses or None;
    make_terms_rhs), ``lo`` the 0-based index of the first bead in the chain (the contact table's offset).
    """
    if terms is not None and any(term is not None for term in terms):
        return make_terms_rhs(beads, exponent, force, *terms, left=left, wall=wall, lo=lo)
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
            try:
                a += on_site(inner, y[1::2])
            except ForceNotFinite as exc:  # the time the force does not know
                raise exc.at(t) from None
        return out

    return rhs


def make_terms_rhs(beads: int, exponent: float, force: OnSiteForce | None, contact, masses, *,
                   left: Boundary | None = None, wall: bool = False, lo: int = 0) -> Callable[[float, Array], Array]:
    """make_rhs with the contact law's term and the masses of beads lo+1..lo+beads:
    m_i x_i'' = F(d_(i-1), w_(i-1)) - F(d_i, w_i) + F_i, F(d, w) = H(d) (d^n + eps_c P_k(d, w)), w = d'.
    A prescribed ``left`` bead (window.Coast: its position and ``velocity``) closes contact lo with
    w = v_left - v_1; a ``wall`` at rest closes contact lo + beads with w = v_last (free ends: no force)."""
    n = float(exponent)
    on_site = None if force is None else force.force
    inverse = np.ones(beads) if masses is None else 1.0 / np.asarray(masses, float)
    k = np.maximum(lo - 1 + np.arange(beads + 1), 0)  # 0-based contact of f[j], the force left of bead j
    xe, ve = np.zeros(beads + 2), np.zeros(beads + 2)  # [0]: the bead before the first, [-1]: the bead after the last

    def rhs(t: float, y: Array) -> Array:
        x, v = y[0::2], y[1::2]
        xe[1:-1], ve[1:-1] = x, v
        xe[0], ve[0] = (left(t), left.velocity) if left is not None else (x[0], v[0])
        xe[-1], ve[-1] = (0.0, 0.0) if wall else (x[-1], v[-1])
        d = xe[:-1] - xe[1:]
        wd = ve[:-1] - ve[1:]
        on = d > 0.0
        f = np.zeros(beads + 1)  # f[j]: force of the contact left of bead j
        dd = d[on]
        f[on] = dd**n + (0.0 if contact is None else contact.value(dd, wd[on], k[on]))
        a = f[:-1] - f[1:]
        if on_site is not None:
            try:
                a = a + on_site(x, v)
            except ForceNotFinite as exc:
                raise exc.at(t) from None
        out = np.empty(2 * beads)
        out[0::2] = v
        out[1::2] = a * inverse
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
    from scipy import sparse

    n = float(exponent)

    def diagonals(t: float, y: Array):
        x, v = y[0::2], y[1::2]
        try:
            lower3, lower1, main, upper1 = _band_diagonals(beads, n, x, v, force)
        except ForceNotFinite as exc:  # the time the force's slopes do not know
            raise exc.at(t) from None
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


def band_pattern(beads: int, upper: int = 1) -> sparse.csc_matrix:
    """Structural sparsity of the Jacobian: neighbours only (offsets -3, -1, 0, +1; with ``upper`` = 3, the
    contact law's rate terms, every offset from -3 to +3)."""
    from scipy import sparse

    m = 2 * beads
    offsets = (-3, -1, 0, 1) if upper == 1 else tuple(range(-3, upper + 1))
    return sparse.diags([np.ones(m - abs(o)) for o in offsets], offsets, shape=(m, m), format="csc")


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
    terms: "tuple | None" = None,
    lo: int = 0,
) -> _integrate.OdeSolver:
    """The scipy OdeSolver for ``method`` with the best Jacobian information available.

    ``left``, ``wall``, ``terms``, ``lo`` as in make_rhs; a moving window restarts the solver at ``t0`` with the
    previous step size as ``first_step``.
    """
    import scipy.integrate as _integrate

    rhs = make_rhs(beads, exponent, force, left, wall, terms, lo)
    cls = getattr(_integrate, method)
    kw = dict(rtol=rtol, atol=atol)
    if first_step is not None:
        kw["first_step"] = min(first_step, t_max - t0)
    if not methods.by_name(method).implicit:
        return cls(rhs, t0, y0, t_max, **kw)
    if terms is not None and any(term is not None for term in terms):  # a rate-dependent contact couples v_(i-1), v_(i+1): band 3
        if method == "LSODA":
            return cls(rhs, t0, y0, t_max, lband=3, uband=3, **kw)
        return cls(rhs, t0, y0, t_max, jac_sparsity=band_pattern(beads, 3), **kw)
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
    RuntimeError (same contract as hairer.run_fortran).
    """
    while True:
        t_old, y_old = solver.t, solver.y.copy()
        message = solver.step()
        if solver.status == "failed":
            raise IntegratorFailed(f"integrator failed at t={solver.t:.6g}: {message}", solver.y.copy())
        if on_step(t_old, y_old, solver.t, solver.y.copy(), solver.dense_output) or solver.status != "running":
            return solver.t, solver.y.copy(), int(solver.nfev), float(solver.step_size or 0.0)


