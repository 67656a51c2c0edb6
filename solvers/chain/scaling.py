"""The scaling symmetry of paper Eq. 1: a run at impact velocity v0 is a rescaled run at v0 = 1.

With x = lam X and t = tau T, where lam = v0^(2/(n+1)) and tau = lam^((1-n)/2), the contact
forces of Eq. 1 keep their form and bead 1's velocity becomes 1 (x' = lam^((n+1)/2) X' = v0 X').
The on-site force maps to

    F'(X, V) = lam^(-n) F(lam X, v0 V),   dF'/dX = lam^(1-n) F_x,   dF'/dV = lam^((1-n)/2) F_v,

so each term c u^a v^b of R has the coefficient c lam^(a + b (n+1)/2 - n) in the unit frame:
the symmetry maps R's coefficients, exactly, but may make them huge. Back in the physical frame
strains scale by lam, times by tau, energies by lam^(n+1) = v0^2.

:func:`simulate` (solvers/chain/dns.py) runs a v0 outside DIRECT_RANGE this way, so that its
state is O(1) and the tolerances act on the wave's own scale (a direct run at v0 = 1e-300 has a
state far below any absolute tolerance; at 1e300 its energy overflows). The unperturbed chain is
exactly invariant, so any v0 in VELOCITY_RANGE runs; with R, the unit-frame force must stay within
FORCE_LIMIT times the contact forces, else the run is refused with the v0 range where it holds.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.chain.equations import DNSResult, OnSiteForce

VELOCITY_RANGE = (1e-150, 1e150)
"""v0 whose energy v0^2/2 is a normal float64 number: beyond it the chain's energy is not representable."""
DIRECT_RANGE = (1e-3, 1e3)
"""v0 integrated as given; outside it the run goes through the unit frame."""
FORCE_LIMIT = 1e8
"""Largest on-site force in the unit frame, relative to the O(1) contact forces there."""
_PROBE = (-1.5, -0.5, 0.0, 0.5, 1.5)  # unit-frame displacements and velocities the force is probed at


class ScalingError(PulsemapError):
    """An impact velocity outside the range where the scaling laws and the integrator hold."""


def check_velocity_range(velocity: float, what: str = "velocity") -> None:
    """Refuse a v0 outside VELOCITY_RANGE (one line, with the range)."""
    lo, hi = VELOCITY_RANGE
    if not lo <= velocity <= hi:
        raise ScalingError(f"{what} = {velocity:g} is outside [{lo:g}, {hi:g}]: the chain's energy v0^2/2 "
                           "must be a float64 number (the DNS rescales any v0 in that range to v0 = 1)")


@dataclass(frozen=True)
class Scaling:
    """x = lam X, t = tau T for impact velocity ``velocity`` and contact exponent ``exponent``."""

    exponent: float
    velocity: float

    @property
    def lam(self) -> float:
        return self.velocity ** (2.0 / (self.exponent + 1.0))

    @property
    def tau(self) -> float:
        return self.lam ** ((1.0 - self.exponent) / 2.0)

    def force(self, force: OnSiteForce | None) -> OnSiteForce | None:
        """The on-site force in the unit frame (None stays None)."""
        if force is None:
            return None
        n, lam, v0 = self.exponent, self.lam, self.velocity
        fx, fv = force.dforce_dx, force.dforce_dv
        restrict = force.restrict
        return OnSiteForce(
            force=lambda X, V: lam ** (-n) * np.asarray(force.force(lam * X, v0 * V), dtype=float),
            dforce_dx=None if fx is None else (lambda X, V: lam ** (1.0 - n) * np.asarray(fx(lam * X, v0 * V), dtype=float)),
            dforce_dv=None if fv is None else (lambda X, V: self.tau * np.asarray(fv(lam * X, v0 * V), dtype=float)),
            stiffness_hint=force.stiffness_hint * self.tau,  # a rate: times tau
            restrict=None if restrict is None else (lambda lo, hi: self.force(restrict(lo, hi))),
            monomials=self.table(force.monomials),
            ramp=force.ramp,
        )

    def table(self, table):
        """A monomial table (chain/compiled.py) in the unit frame: c u^a v^b -> c lam^(a-n) v0^b X^a V^b."""
        if table is None:
            return None
        a, b = table.exponents[:, 0], table.exponents[:, 1]
        factor = self.lam ** (a - self.exponent) * self.velocity ** b
        return type(table)(table.exponents, table.coefficients * factor[:, None])

    def unit_force_size(self, force: OnSiteForce, beads: int) -> float:
        """max |F'| over a grid of unit-frame states (NaN-free: a non-finite value counts as inf)."""
        size = 0.0
        scaled = self.force(force)
        with np.errstate(all="ignore"):
            for X in _PROBE:
                for V in _PROBE:
                    f = np.asarray(scaled.force(np.full(beads, X), np.full(beads, V)), dtype=float)
                    if not np.all(np.isfinite(f)):
                        return math.inf
                    size = max(size, float(np.max(np.abs(f))) if f.size else 0.0)
        return size

    def contact(self, contact):
        """The contact law's term in the unit frame: c d^a w^b -> c lam^(a + b - n) tau^(-b) D^a W^b."""
        if contact is None:
            return None
        from pulsemap.solvers.chain.contact_force import ContactTable

        a, b = contact.exps[:, 0], contact.exps[:, 1]
        factor = self.lam ** (a + b - self.exponent) * self.tau ** (-b)
        return ContactTable(contact.exps, contact.coef * factor[:, None])

    def result(self, res: DNSResult) -> DNSResult:
        """A unit-frame result in the physical frame of ``velocity``."""
        lam, tau, e = self.lam, self.tau, self.velocity ** 2

        def scaled(a, factor):
            return None if a is None else np.asarray(a, dtype=float) * factor

        snaps = tuple(dataclasses.replace(s, time=s.time * tau, strains=np.asarray(s.strains) * lam)
                      for s in res.snapshots)
        return dataclasses.replace(
            res, peaks=res.peaks * lam, peak_times=res.peak_times * tau, velocity=self.velocity, t_end=res.t_end * tau,
            energy_initial=res.energy_initial * e, pulse_energy=scaled(res.pulse_energy, e),
            total_energy=scaled(res.total_energy, e), snapshots=snaps,
            stop_reason=f"{res.stop_reason} [run at v0 = 1 and rescaled: x by {lam:.3g}, t by {tau:.3g}]")


def needs_rescaling(velocity: float) -> bool:
    return not DIRECT_RANGE[0] <= velocity <= DIRECT_RANGE[1]


def check_force_range(force: OnSiteForce | None, exponent: float, velocity: float, beads: int) -> None:
    """Refuse a v0 at which the unit-frame on-site force exceeds FORCE_LIMIT, naming the v0 range where it does not."""
    if force is None or Scaling(exponent, velocity).unit_force_size(force, beads) <= FORCE_LIMIT:
        return
    lo, hi = _holding_range(force, exponent, beads)
    size = Scaling(exponent, velocity).unit_force_size(force, beads)
    shown = "not finite" if not math.isfinite(size) else f"{size:.3g} times the contact forces"
    where = f"v0 in [{lo:.3g}, {hi:.3g}]" if lo <= hi else "no v0 tried"
    raise ScalingError(
        f"velocity = {velocity:g}: scaled to v0 = 1 (Eq. 1's symmetry maps R's coefficients) the on-site force "
        f"is {shown} (limit {FORCE_LIMIT:g}), beyond what the integrator holds; for this R: {where}")


def _holding_range(force: OnSiteForce, exponent: float, beads: int) -> tuple[float, float]:
    """The v0 range around 1 where the unit-frame force stays within FORCE_LIMIT (bisection in log v0)."""

    def ok(log_v: float) -> bool:
        return Scaling(exponent, 10.0 ** log_v).unit_force_size(force, beads) <= FORCE_LIMIT

    if not ok(0.0):
        return math.inf, -math.inf
    ends = []
    for edge in (math.log10(VELOCITY_RANGE[0]), math.log10(VELOCITY_RANGE[1])):
        if ok(edge):
            ends.append(10.0 ** edge)
            continue
        good, bad = 0.0, edge
        for _ in range(40):
            mid = 0.5 * (good + bad)
            good, bad = (mid, bad) if ok(mid) else (good, mid)
        ends.append(10.0 ** good)
    return ends[0], ends[1]
