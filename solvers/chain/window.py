"""Moving-window DNS of paper Eq. 1: integrate only the beads near the leading edge.

    x_i'' = (x_{i-1} - x_i)_+^n - (x_i - x_{i+1})_+^n + F_i(x_i, x_i')          (paper Eq. 1)

The primary pulse spans about six beads and its leading and trailing edges decay
super-exponentially (delta_{i+1} ~ delta_i^n ahead of the front), so

* beads far ahead of the front are at rest to round-off: they are not integrated; the bead just
  past the window (0-based index ``hi``) is held at rest at x = 0 (a wall for the contact
  between beads hi-1 and hi), exactly as in the full chain while its true motion is below
  round-off. A step after which bead hi-1 moves by more than ``threshold`` (relative to the
  scales v0 and v0^(2/(n+1))) is rejected and redone with a wider window;
* beads more than ``behind`` beads behind the last peaked contact (the front) no longer
  influence the leading-edge peaks: they are dropped in chunks of ``chunk`` beads. The last
  dropped bead becomes a prescribed left boundary: it coasts with its velocity at the moment
  it was dropped (``boundary="coast"``), or it is removed with its contact (``"free"``).

With a contact law's term eps_c P_k(d, w) and masses (the Chain's contact and masses) the same holds: the
coasting bead closes its contact with w = v_coast - v_lo, the wall with w = v_(hi-1), the contact table is read at
the chain's own contact indices and the window's masses divide the forces (equations.make_terms_rhs); beads
behind a damped pulse or a mass step keep moving, and the coasting bead carries that momentum.

The scipy solver is restarted at every shift with the last step size as its first step, so a
shift costs one or two right-hand-side evaluations. The cost per contact is independent of the
chain length N (the full chain costs O(N) per contact, O(N^2) per run).

The window rule (``rule_for_accuracy``) was calibrated against the full chain (peaks at every
contact, n = 1.5 and n = 3, v0 = 1, unperturbed and damped from bead 16); see docs/dns.rst
("Window calibration") and benchmarks/bench_dns_scaling.py.
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from pulsemap.solvers.chain.errors import DNSInputError
from pulsemap.solvers.chain.equations import (ENERGY_BLOWUP, DNSResult, IntegratorFailed, energy, largest_force, make_rhs,
                                              make_solver, run_scipy)
from pulsemap.solvers.chain.front import memo, state_at
from pulsemap.solvers.chain.dns_progress import DNSProgress
from pulsemap.solvers.chain.hairer import FORTRAN_CODES, run_fortran
from pulsemap.solvers.chain.peaks import PeakTracker, StopRules, scan_step, velocity_scale

if TYPE_CHECKING:  # pragma: no cover
    from pulsemap.solvers.chain.dns import Chain, Integrator
    from pulsemap.solvers.chain.plan import Plan

Array = np.ndarray
BOUNDARIES = ("coast", "free")

#: (accuracy floor, behind) of rule_for_accuracy: the fewest beads behind whose measured worst peak
#: error against the full chain is at least 3x below the accuracy (10x from 1e-8 on) and past the
#: cliff at 13; below 1e-9 the integrator's floor (the calibration: docs/dns.rst, "Window calibration").
BEHIND_FOR: tuple[tuple[float, int], ...] = ((1e-7, 16), (1e-8, 18), (1e-9, 22), (0.0, 24))
#: Beads added behind for a dissipative contact term of strength gamma (ContactTable.damping at the run's strain
#: scale): ceil(DAMPED_BEHIND x max(gamma^DAMPED_POWER, gamma) x DAMPED_GROWTH^max(0, n - 3/2) x (1 + DAMPED_PER_DECADE
#: x decades of accuracy below 1e-8)). A damped pulse leaves its beads moving with loaded contacts, which push the front
#: once the pulse has decayed; the fewest beads behind for a third of the accuracy down to 10 % of the entry peak,
#: dashpot and Kuwabara-Kono eps c 0.05..2 at n = 3/2..3, accuracies 1e-6..1e-10 (docs/contact.rst, "The moving window
#: and damped contacts"); n <= 3/2 with gamma <= 1 at 1e-8 or looser is the first calibration, unchanged.
DAMPED_BEHIND, DAMPED_POWER = 46.0, 0.6
DAMPED_GROWTH, DAMPED_PER_DECADE = 4.0, 0.15
#: Ahead threshold = accuracy x this / max(1, gamma)^2: it moves the peaks by ~5x itself at most without a dissipative
#: term; above gamma = 1 a damped front's precursor reaches further ahead and the threshold costs up to ~20 gamma^2 x
#: itself (docs/contact.rst, "The moving window and damped contacts").
THRESHOLD_FRACTION = 1e-2
DEFAULT_WINDOW_ACCURACY = 1e-8  # simulate's window accuracy unless rtol asks for less (window_accuracy_for)
#: The largest ratio of neighbouring masses an 'auto' window takes; above it the full chain runs: behind a sharper
#: contrast the wake keeps beads moving, and a dropped bead coasting at its drop velocity drives the window like a
#: piston (the evidence: docs/dns.rst, "The moving window and uneven masses").
MASS_STEP_LIMIT = 1.5


@dataclass(frozen=True)
class WindowRule:
    """Geometry of the moving window (bead counts).

    behind: beads kept behind the front (the last peaked contact);
    ahead: beads kept ahead of the next contact to peak (at rest up to round-off);
    chunk: beads dropped/added per shift (amortises the solver restart);
    threshold: motion of the last window bead, relative to the scales v0^(2/(n+1)) and v0,
      that triggers a wider window;
    boundary: what the last dropped bead does: "coast" (constant velocity) or "free" (removed).
    """

    behind: int = 20
    ahead: int = 10
    chunk: int = 10
    threshold: float = 1e-30
    boundary: str = "coast"

    @property
    def width(self) -> int:
        """Largest number of beads integrated at once."""
        return self.behind + self.ahead + self.chunk + 1


def validate_rule(rule: WindowRule) -> WindowRule:
    """One-line ValueErrors for a bad window geometry."""
    if rule.behind < 2 or rule.ahead < 2 or rule.chunk < 1:
        raise DNSInputError(f"window needs behind >= 2, ahead >= 2, chunk >= 1, got {rule!r}")
    if not (np.isfinite(rule.threshold) and 0.0 < rule.threshold < 1.0):
        raise DNSInputError(f"window threshold must lie in (0, 1), got {rule.threshold!r}")
    if rule.boundary not in BOUNDARIES:
        raise DNSInputError(f"window boundary must be one of {BOUNDARIES}, got {rule.boundary!r}")
    return rule


def rule_for_accuracy(accuracy: float, damping: float = 0.0, exponent: float = 1.5) -> WindowRule:
    """Window rule whose truncation error stays below ``accuracy`` (relative peak error).

    Calibrated rule (BEHIND_FOR; docs/dns.rst, "Window calibration"): 16 beads behind down to 1e-7,
    18 down to 1e-8, 22 down to 1e-9, 24 below (the integrator's floor); ahead, a bead is added when the last one moves by accuracy / 100 of the
    scales v0^(2/(n+1)) and v0. A dissipative contact term of strength ``damping`` adds damped_behind(damping,
    exponent, accuracy) (``exponent`` n is read only there) and, above 1, divides the threshold by damping^2.
    """
    if not (np.isfinite(accuracy) and 0.0 < accuracy < 1.0):
        raise DNSInputError(f"window_accuracy must lie in (0, 1), got {accuracy!r}")
    behind = next(b for floor, b in BEHIND_FOR if accuracy >= floor) + damped_behind(damping, exponent, accuracy)
    threshold = THRESHOLD_FRACTION * float(accuracy) / max(1.0, damping) ** 2
    return WindowRule(behind=behind, threshold=max(threshold, 1e-30))


def damped_behind(damping: float, exponent: float = 1.5, accuracy: float = DEFAULT_WINDOW_ACCURACY) -> int:
    """Beads the window keeps behind the front beyond the calibrated rule for a contact term of damping ``damping``
    (contact_force.ContactTable.damping; 0: none) at Hertz exponent ``exponent`` and window ``accuracy``: the loaded
    tail behind a damped pulse reaches further at larger n and for a stronger term (DAMPED_BEHIND's line)."""
    if damping <= 0.0:
        return 0
    strength = max(damping**DAMPED_POWER, damping)
    decades = max(0.0, math.log10(DEFAULT_WINDOW_ACCURACY / accuracy))
    widening = DAMPED_GROWTH ** max(0.0, exponent - 1.5) * (1.0 + DAMPED_PER_DECADE * decades)
    return int(math.ceil(DAMPED_BEHIND * strength * widening))


@dataclass(frozen=True)
class WindowSpec:
    """The moving window simulate() is asked for: ``size`` 'auto' (rule_for_accuracy), an int width or
    a WindowRule; ``accuracy``: the relative peak error the 'auto' rule may cost (None: the looser of
    rtol and DEFAULT_WINDOW_ACCURACY, window_accuracy_for); ``engine``: the scipy engine's window
    integrator, 'auto' (Hairer's Fortran codes for DOP853 and RK45, else scipy's OdeSolver),
    'fortran' or 'scipy'."""

    size: "int | str | WindowRule" = "auto"
    accuracy: float | None = None
    engine: str = "auto"

    @classmethod
    def of(cls, window: "WindowSpec | int | str | WindowRule | None") -> "WindowSpec | None":
        """simulate's ``window``: None (the full chain), a WindowSpec, or a size alone ('auto', an int
        width, a WindowRule) with the default accuracy and engine."""
        return window if window is None or isinstance(window, WindowSpec) else cls(size=window)


def window_accuracy_for(rtol: float, window_accuracy: "float | None") -> float:
    """The window's accuracy: ``window_accuracy`` as given, else (None) the looser of rtol and
    DEFAULT_WINDOW_ACCURACY (the window never costs more than the integrator's tolerance asks, nor
    more than 1e-8), capped below 1e-3."""
    if window_accuracy is not None:
        return window_accuracy
    return min(max(float(rtol), DEFAULT_WINDOW_ACCURACY), 1e-3)


MIN_WIDTH = 17  # the narrowest width whose rule keeps behind >= 2 (10 ahead, chunk 4, 1 for the front)


def rule_for_width(width: int) -> WindowRule:
    """Window rule with ``width`` integrated beads at most (ahead 10, chunk ~ width/4)."""
    if isinstance(width, bool) or not isinstance(width, (int, np.integer)) or width < MIN_WIDTH:
        raise DNSInputError(f"window width must be an integer >= {MIN_WIDTH}, got {width!r}; or use window='auto'")
    chunk = max(1, int(width) // 4)
    ahead = 10
    return WindowRule(behind=int(width) - ahead - chunk - 1, ahead=ahead, chunk=chunk)


def resolve_rule(window, accuracy: float, damping: float = 0.0, exponent: float = 1.5,
                 mass_step: float = 1.0) -> WindowRule | None:
    """``window`` as given to simulate(): 'auto' (rule_for_accuracy(accuracy, damping, exponent); None, the full
    chain, where neighbouring masses differ by more than MASS_STEP_LIMIT: ``mass_step``, largest_mass_step's), an int
    width, or a WindowRule (those two as given)."""
    if isinstance(window, WindowRule):
        return validate_rule(window)
    if isinstance(window, str):
        if window != "auto":
            raise DNSInputError(f"window must be None, 'auto', an int width or a WindowRule, got {window!r}")
        return None if full_chain_because(mass_step) else rule_for_accuracy(accuracy, damping, exponent)
    return validate_rule(rule_for_width(window))


def largest_mass_step(masses) -> float:
    """The largest ratio of neighbouring masses (1.0: unit or no masses), which an 'auto' window reads."""
    if masses is None or len(masses) < 2:
        return 1.0
    return float(np.exp(np.max(np.abs(np.diff(np.log(masses))))))


def full_chain_because(mass_step: float) -> str:
    """Why an 'auto' window runs the full chain over masses whose neighbours differ by up to ``mass_step``
    (largest_mass_step), "" where it does not: resolve_rule's test, and the run's report of it."""
    if mass_step > MASS_STEP_LIMIT:
        return f"neighbouring masses differ by up to {mass_step:.3g}x, beyond the moving window's {MASS_STEP_LIMIT:g}x"
    return ""


# ----------------------------------------------------------------------------- Eq. 1 on a window


def restrict_force(force, beads: int, lo: int, hi: int):
    """The on-site force on beads lo..hi-1 (0-based) as an OnSiteForce on the window.

    Uses ``force.restrict(lo, hi)`` when the force provides it (O(window) per call); otherwise
    embeds the window in full-length arrays (beads outside it at 0: the force is on-site, so
    their values never matter), which costs O(N) per call but works for any force.
    """
    if force is None:
        return None
    if force.restrict is not None:
        return force.restrict(lo, hi)
    xf, vf = np.zeros(beads), np.zeros(beads)

    def embed(fn):
        if fn is None:
            return None

        def on_window(x: Array, v: Array) -> Array:
            xf[lo:hi] = x
            vf[lo:hi] = v
            return np.asarray(fn(xf, vf), float)[lo:hi]

        return on_window

    return replace(force, force=embed(force.force), dforce_dx=embed(force.dforce_dx),
                   dforce_dv=embed(force.dforce_dv), restrict=None)


@dataclass(frozen=True)
class Coast:
    """Prescribed left boundary bead: at x_b + v_b (t - t_b); its ``velocity`` v_b closes the contact law's rate."""

    x_b: float
    velocity: float
    t_b: float

    def __call__(self, t: float) -> float:
        return self.x_b + self.velocity * (t - self.t_b)


def window_energy(y: Array, exponent: float, left_x: float | None, masses: Array | None = None) -> float:
    """Energy of Eq. 1 in the window (``masses``: the window's, None: all 1), with the contact to the prescribed
    left bead (Hertz part only: a contact law's term is dissipative or elastic, the energy is the blow-up guard's)."""
    x, v = y[0::2], y[1::2]
    e = energy(x, v, exponent, masses)
    if left_x is not None and left_x > x[0]:
        e += (left_x - x[0]) ** (exponent + 1.0) / (exponent + 1.0)
    return e


def moved(y: Array, scale_x: float, scale_v: float) -> float:
    """Motion of the last window bead relative to the chain's scales."""
    return abs(y[-2]) / scale_x + abs(y[-1]) / scale_v


# ----------------------------------------------------------------------------- the run


@dataclass
class _Run:
    """Mutable window geometry of one windowed run (internal to simulate_windowed)."""

    lo: int
    hi: int
    left: Coast | None = None
    drift: float = 0.0
    e_gone: float = 0.0
    action: str = ""  # "", "stop", "shift", "extend"
    redo: tuple[float, Array] | None = None
    wall_report: float = 0.0


ENERGY_EVERY = 4  # the blow-up guard computes the window's energy every this many steps


def plan(next_contact: int, lo: int, hi: int, beads: int, rule: WindowRule) -> tuple[int, int]:
    """New [lo, hi) for the window given the next contact to peak (1-based; the front, the last
    peaked contact, is next_contact - 1)."""
    new_lo = max(lo, next_contact - 1 - rule.behind)
    new_hi = min(beads, max(hi, next_contact + rule.ahead + rule.chunk))
    return new_lo, new_hi


def needs_shift(next_contact: int, lo: int, hi: int, beads: int, rule: WindowRule) -> bool:
    """True when a chunk can be dropped behind the front or the room ahead is used up."""
    droppable = next_contact - 1 - rule.behind - lo >= rule.chunk
    short = hi < beads and hi - next_contact < rule.ahead
    return droppable or short


def shift_state(y: Array, lo: int, new_lo: int, new_hi: int) -> Array:
    """Interleaved state of window [new_lo, new_hi) from that of the window starting at lo
    (new_lo >= lo; beads past the old window at rest)."""
    out = np.zeros(2 * (new_hi - new_lo))
    keep = y[2 * (new_lo - lo) :]
    out[: len(keep)] = keep
    return out


def simulate_windowed(chain: "Chain", contacts: tuple[int, int], how: "Plan", integrator: "Integrator",
                      stop: StopRules, *, progress: bool = False, front=None) -> DNSResult:
    """Moving-window integration of Eq. 1 on the scipy engine (arguments validated by dns.simulate, which calls it,
    and handed down as they are): ``chain`` (N, n, v0 or its launch, the on-site force), ``how`` (plan()'s Plan:
    the method, the window rule and the window engine, "fortran" for Hairer's DOP853/DOPRI5 through
    scipy.integrate.ode, about 2x less overhead per step on a small window, or "scipy" for the OdeSolver
    classes), ``integrator`` (rtol, atol), ``stop`` (with t_max and max_steps given), ``front`` a
    front.FrontRecorder (energies, snapshots). A launch (solvers.chain.launch.Launch) starts from that exact
    solitary wave instead of the impact v0 on bead 1 (its velocity scale then stands for v0).
    """
    beads, exponent, force, launch = chain.beads, chain.exponent, chain.force, chain.launch
    contact, masses = chain.contact, chain.masses
    velocity = chain.velocity if launch is None else launch.velocity_scale(exponent)
    method, rule, engine, rtol, atol = how.method, how.rule, how.window_engine, integrator.rtol, integrator.atol
    assert engine == "scipy" or (engine == "fortran" and method in FORTRAN_CODES), (engine, method)  # plan() chose
    first, last = int(contacts[0]), int(contacts[1])
    scale_x, scale_v = velocity_scale(velocity, exponent), velocity
    moving = 1 if launch is None else launch.front(exponent)  # beads in motion at t = 0
    run = _Run(lo=0, hi=min(beads, moving + rule.ahead + rule.chunk + 1))
    report = DNSProgress("dns-window", last, enabled=progress)
    track = PeakTracker.start(first, last, velocity, exponent, stop,
                              next_contact=1 if launch is None else launch.centre + 1, method=method)
    t_max, max_steps = float(stop.t_max), int(stop.max_steps)
    if launch is None:
        y = np.zeros(2 * run.hi)
        y[1] = velocity
    else:
        y = launch.state(exponent, run.hi)
    t = 0.0

    def window_masses() -> Array | None:
        return None if masses is None else masses[run.lo:run.hi]

    e0 = window_energy(y, exponent, None, window_masses())
    nfev = njev = shifts = 0
    widest = run.hi - run.lo
    h: float | None = None
    wall0 = run.wall_report = _time.perf_counter()

    def on_step(t_old: float, y_old: Array, t_new: float, y_new: Array, dense_factory) -> bool:
        """Bookkeeping after one accepted step; True asks the engine to stop."""
        if run.hi < beads and moved(y_new, scale_x, scale_v) > rule.threshold:
            run.action, run.redo = "extend", (t_old, y_old)  # precursor reached the edge
            return True
        if track.steps % ENERGY_EVERY == 0 or not np.isfinite(y_new[-1] + y_new[0]):
            left_x = None if run.left is None else run.left(t_new)
            e = window_energy(y_new, exponent, left_x, window_masses()) + run.e_gone
            if track.check_state(t_new, e, e0, ENERGY_BLOWUP):
                run.action = "stop"
                return True
            run.drift = max(run.drift, abs(e - e0) / e0)
        local_last = min(last, run.hi - 1) - run.lo
        dense = memo(dense_factory)
        found = scan_step(y_old, y_new, t_old, t_new, dense, track.next_contact - run.lo,
                          local_last, track.threshold, stop.peak_fraction)
        track.record(found, offset=run.lo)
        if found and front is not None:
            front.record(found, state_at(dense()), offset=run.lo, extra_energy=run.e_gone)
        if track.check_progress(t_new, t_max, max_steps):
            run.action = "stop"
            return True
        report.update(t_new, track.next_contact - 1, f"{method}, window beads {run.lo + 1}..{run.hi}")
        if needs_shift(track.next_contact, run.lo, run.hi, beads, rule):
            run.action = "shift"
            return True
        return False

    while True:
        width = run.hi - run.lo
        force_w = restrict_force(force, beads, run.lo, run.hi)
        wall = run.hi < beads
        terms = (contact, window_masses())
        run.action, run.redo = "", None
        try:
            if engine == "fortran":
                rhs = make_rhs(width, exponent, force_w, run.left, wall, terms, run.lo)
                t, y, used, h = run_fortran(FORTRAN_CODES[method], rhs, t, y, t_max, rtol, atol, h, on_step)
            else:
                solver = make_solver(method, width, exponent, force_w, y, t_max, rtol, atol,
                                     t0=t, first_step=h, left=run.left, wall=wall, terms=terms, lo=run.lo)
                t, y, used, h = run_scipy(solver, on_step)
                njev += int(getattr(solver, "njev", 0))
        except RuntimeError as err:
            track.reason = str(err) + (largest_force(force_w, err.y, run.lo) if isinstance(err, IntegratorFailed) else "")
            break
        nfev += used
        if run.action == "stop" or not run.action:
            track.reason = track.reason or f"t_max reached (t={t:.6g}, next contact {track.next_contact})"
            break
        shifts += 1
        if run.action == "extend":
            t, y = run.redo
            add = min(beads, run.hi + rule.chunk) - run.hi
            y = np.concatenate([y, np.zeros(2 * add)])
            run.hi += add
        else:  # shift: drop beads behind, add beads ahead
            new_lo, new_hi = plan(track.next_contact, run.lo, run.hi, beads, rule)
            e_before = window_energy(y, exponent, None if run.left is None else run.left(t), window_masses())
            y_shifted = shift_state(y, run.lo, new_lo, new_hi)
            if new_lo > run.lo:
                j = new_lo - run.lo - 1  # local index of the last dropped bead
                run.left = Coast(y[2 * j], y[2 * j + 1], t) if rule.boundary == "coast" else None
            run.lo, run.hi, y = new_lo, new_hi, y_shifted
            run.e_gone += e_before - window_energy(y, exponent, None if run.left is None else run.left(t),
                                                   window_masses())
        widest = max(widest, run.hi - run.lo)

    wall_s = _time.perf_counter() - wall0
    return DNSResult.tracked(
        track, front, method=method, rtol=float(rtol), atol=float(atol), beads=beads, nfev=int(nfev), njev=int(njev),
        wall_time_s=wall_s, energy_drift=run.drift if force is None else None, exponent=exponent, velocity=velocity,
        t_end=float(t), energy_initial=e0, mode=f"window/{engine}", window_beads=int(widest),
        window_shifts=int(shifts), window_rule=rule,
    )
