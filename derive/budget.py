"""The time bound and the progress report of one derivation (``derive --max-seconds``).

A :class:`Budget` is checked between the steps of a derivation (the expansion, each profile
integral, the law, Eq. 41); past its bound the derivation stops with :class:`DeriveTimeout`
naming what it was doing and how far it got. Integrals computed so far stay in the on-disk
cache, so running again with a larger bound resumes where this one stopped. Progress lines
("derive: integrals 120/1089, 14 s") go to ``report`` at most once a second.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable

from pulsemap.symbolic.errors import PulsemapError

#: Largest --max-seconds (a day); None means no bound.
MAX_SECONDS_LIMIT = 86400.0


class DeriveTimeout(PulsemapError):
    """The derivation did not finish within its time bound (the message says where it stopped)."""


def check_max_seconds(value: object, error: type[ValueError] = ValueError) -> float | None:
    """``value`` as a float in (0, 86400], or None; else ``error`` naming max_seconds and the range."""
    if value is None:
        return None
    if isinstance(value, (bool, str)):
        raise error(f"max_seconds must be a number (0 < max_seconds <= {MAX_SECONDS_LIMIT:g}) or None, got {value!r}")
    try:
        seconds = float(value)
    except (TypeError, ValueError):
        raise error(f"max_seconds must be a number (0 < max_seconds <= {MAX_SECONDS_LIMIT:g}) or None, got {value!r}") from None
    if not (math.isfinite(seconds) and 0 < seconds <= MAX_SECONDS_LIMIT):
        raise error(f"max_seconds = {seconds:g} is outside 0 < max_seconds <= {MAX_SECONDS_LIMIT:g}")
    return seconds


@dataclass
class Budget:
    """Time bound (None: unbounded) and progress reporter (None: silent) of one derivation."""

    max_seconds: float | None = None
    report: Callable[[str], None] | None = None
    start: float = field(default_factory=time.perf_counter)
    _last: float = field(default=-math.inf, repr=False)

    def __post_init__(self) -> None:
        self._last = self.start  # quick derivations print nothing: the first line comes after 1 s

    def elapsed(self) -> float:
        return time.perf_counter() - self.start

    def remaining(self) -> float:
        """Seconds left (inf when unbounded, 0 when spent)."""
        return math.inf if self.max_seconds is None else max(0.0, self.max_seconds - self.elapsed())

    def check(self, what: str) -> None:
        """Raise DeriveTimeout if the bound has passed; ``what`` says where the derivation is."""
        if self.max_seconds is not None and self.elapsed() > self.max_seconds:
            raise DeriveTimeout(
                f"derive stopped after {self.elapsed():.1f} s (max_seconds = {self.max_seconds:g}) during {what}: "
                "the integrals done so far are cached, so a run with a larger bound resumes; or simplify R"
            )

    def step(self, what: str, k: int, total: int) -> None:
        """Check the bound at step k of total, and report progress at most once a second (and at the end)."""
        self.check(f"{what} ({k} of {total} done)")
        now = time.perf_counter()
        if self.report is not None and total > 1 and now - self._last >= 1.0:
            self.report(f"derive: {what} {k}/{total}, {now - self.start:.0f} s")
            self._last = now

