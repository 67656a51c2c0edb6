"""What the DNS records about the front as each contact peaks (energies, strain snapshots).

When contact k reaches its leading-edge peak (peaks.py) at time t_k, the state at t_k gives

* the energy carried by the pulse: kinetic plus contact energy of Eq. 1 over the beads within
  ``PULSE_HALF_WIDTH`` of contact k (beads k-8..k+8 and the contacts between them). For the
  unperturbed chain this is E_1 A^(n+1) (derive/balance.py) with A = peak / S(0) (Eq. 32): the
  solitary wave is narrower than 8 beads on each side, its wake is not;
* the total energy of the integrated beads (kinetic plus contact, no on-site potential), the
  chain's own accuracy check when R = 0 (it is conserved);
* optionally a snapshot of the strains delta_j = x_j - x_{j+1} for j = k-behind..k+ahead, to
  plot how the profile dresses as the pulse travels.

The pulse speed (contacts per unit time) follows from the peak times alone (``pulse_speed``).
Shared by the full-chain DNS (dns.py) and the moving window (window.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from pulsemap.solvers.chain.errors import DNSInputError
from pulsemap.solvers.chain.methods import MAX_BEADS
from pulsemap.solvers.chain.peaks import Peak, QuinticStep

Array = np.ndarray
PULSE_HALF_WIDTH = 8  # beads on each side of the peaked contact that carry the pulse
SNAPSHOT_SPAN = (12, 4)  # default snapshot: contacts behind and ahead of the peaked one
MAX_SNAPSHOT_SPAN = MAX_BEADS  # a wider span holds no more contacts than the longest chain


@dataclass(frozen=True)
class Snapshot:
    """Strains delta_j at the time contact ``contact`` peaks, j = first_contact, first_contact+1, ..."""

    contact: int
    time: float
    first_contact: int
    strains: Array

    def as_dict(self) -> dict:
        return {"contact": self.contact, "time": self.time,
                "contacts": list(range(self.first_contact, self.first_contact + len(self.strains))),
                "strains": [float(s) for s in self.strains]}


def segment_energy(y: Array, exponent: float, lo: int, hi: int) -> float:
    """Kinetic + contact energy of local beads lo..hi-1 (0-based in the interleaved state y) and
    of the contacts between them (Eq. 1's energy restricted to a segment)."""
    x, v = y[0::2][lo:hi], y[1::2][lo:hi]
    d = np.maximum(x[:-1] - x[1:], 0.0)
    return float(0.5 * np.dot(v, v) + np.sum(d ** (exponent + 1.0)) / (exponent + 1.0))


def pulse_energy(y: Array, k: int, exponent: float, offset: int = 0) -> float:
    """Energy of beads k-8..k+8 (1-based, clipped to the state) when contact k peaks; ``y`` holds
    beads offset+1, offset+2, ... (a moving window starts at bead offset+1)."""
    beads = len(y) // 2
    local = k - 1 - offset  # 0-based local index of bead k
    return segment_energy(y, exponent, max(0, local - PULSE_HALF_WIDTH), min(beads, local + PULSE_HALF_WIDTH + 1))


def strains_around(y: Array, k: int, behind: int, ahead: int, offset: int = 0) -> tuple[int, Array]:
    """(first contact, strains) for contacts k-behind..k+ahead present in the state (1-based)."""
    x = y[0::2]
    lo = max(offset + 1, k - behind)
    hi = min(offset + len(x) - 1, k + ahead)
    j = np.arange(lo, hi + 1) - offset  # 1-based local contact indices
    return lo, (x[j - 1] - x[j]).copy()


def pulse_speed(times: Array) -> Array:
    """Contacts per unit time at each contact: 1 / (d t_k / d k) by central differences of the
    peak times (one-sided at the ends of the run of measured times); NaN where a time is missing.
    The unperturbed wave delta_k(t) = A S(A^s t - k) travels at A^s."""
    t = np.asarray(times, dtype=float)
    out = np.full(t.shape, np.nan)
    measured = int(np.argmin(np.isfinite(t))) if not np.isfinite(t).all() else t.size  # contacts peak in order
    if measured < 2:
        return out
    dt = np.gradient(t[:measured])
    with np.errstate(divide="ignore"):
        out[:measured] = np.where(dt > 0, 1.0 / np.where(dt > 0, dt, 1.0), np.nan)
    return out


@dataclass
class FrontRecorder:
    """Energies (and snapshots at chosen contacts) as each requested contact peaks."""

    first: int
    last: int
    exponent: float
    snapshot_contacts: frozenset = frozenset()
    span: tuple[int, int] = SNAPSHOT_SPAN
    pulse: Array = field(init=False)
    total: Array = field(init=False)
    snapshots: list = field(default_factory=list)

    def __post_init__(self) -> None:
        self.pulse = np.full(self.last - self.first + 1, np.nan)
        self.total = np.full(self.last - self.first + 1, np.nan)

    def record(self, found: Sequence[Peak], state_at: Callable[[float], Array], offset: int = 0,
               extra_energy: float = 0.0) -> None:
        """For each peak of a requested contact: the state at its time from ``state_at`` (the
        step's dense output); ``extra_energy`` is added to the total (energy of dropped beads)."""
        for peak in found:
            k = peak.contact + offset
            if not self.first <= k <= self.last:
                continue
            y = np.asarray(state_at(peak.time), dtype=float)
            self.pulse[k - self.first] = pulse_energy(y, k, self.exponent, offset)
            self.total[k - self.first] = segment_energy(y, self.exponent, 0, len(y) // 2) + extra_energy
            if k in self.snapshot_contacts:
                lo, strains = strains_around(y, k, self.span[0], self.span[1], offset)
                self.snapshots.append(Snapshot(k, float(peak.time), lo, strains))


@dataclass(frozen=True)
class Snapshots:
    """The strain profiles a DNS keeps: at the peak time of each contact k in ``contacts``, the strains
    of contacts k - span[0] .. k + span[1] (``span``: how many behind and ahead). One-line ValueError
    on a bad span; the contacts are checked against the run's range by check_snapshot_contacts."""

    contacts: tuple[int, ...] = ()
    span: tuple[int, int] = SNAPSHOT_SPAN

    def __post_init__(self) -> None:
        span = self.span
        if (isinstance(span, (str, bytes)) or not hasattr(span, "__len__") or len(span) != 2
                or not all(_integer(s) and 0 <= s <= MAX_SNAPSHOT_SPAN for s in span)):
            raise DNSInputError(f"snapshot span must be a pair (behind, ahead) of integers in 0..{MAX_SNAPSHOT_SPAN}, "
                                 f"got {span!r}"[:200])
        contacts = self.contacts
        if isinstance(contacts, (str, bytes)) or not hasattr(contacts or (), "__iter__"):
            raise DNSInputError(f"snapshot contacts must be a sequence of integers >= 1, got {contacts!r}"[:200])
        contacts = tuple(contacts or ())
        for c in contacts:
            if not (_integer(c) and c >= 1):
                raise DNSInputError(f"snapshot contact {c!r} must be an integer >= 1 (a contact of the chain)"[:200])
        object.__setattr__(self, "contacts", tuple(int(c) for c in contacts))
        object.__setattr__(self, "span", (int(span[0]), int(span[1])))


def _integer(value) -> bool:
    """An int (numpy's too), not a bool."""
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool)


def check_snapshot_contacts(contacts: Sequence[int] | None, first: int, last: int) -> frozenset:
    """The requested snapshot contacts as a set; each must lie in first..last (one-line ValueError)."""
    if not contacts:
        return frozenset()
    out = set()
    for c in contacts:
        if not (_integer(c) and first <= c <= last):
            raise DNSInputError(f"snapshot contact {c!r} must be an integer in the reported range {first}..{last}")
        out.add(int(c))
    return frozenset(out)


def memo(factory: Callable[[], Callable]) -> Callable[[], Callable]:
    """The dense-output factory called at most once per step, however many users it has."""
    made: list = []

    def once() -> Callable:
        if not made:
            made.append(factory())
        return made[0]

    return once


def state_at(dense) -> Callable[[float], Array]:
    """The state at a time inside the step: the dense output, or for a QuinticStep its exact re-step."""
    return dense.exact if isinstance(dense, QuinticStep) else dense
