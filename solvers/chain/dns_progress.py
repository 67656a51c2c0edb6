"""Progress of one long DNS run on stderr: contacts k of N, simulated time, elapsed time and ETA.

One plain line at most every ``every`` seconds (none for a run shorter than that), flushed, with
no terminal codes, so it reads the same on a terminal and in a log file. The ETA assumes the
time per contact stays what it has been since the run started (the pulse's cost per contact is
steady once it has formed).
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from typing import Callable

EVERY_S = 5.0


def duration(seconds: float) -> str:
    """'8.2 s', '45 s', '2 min 05 s', '1 h 02 min' (every progress line, DNS and studies)."""
    if seconds < 10:
        return f"{seconds:.1f} s"
    s = int(round(seconds))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {(s % 3600) // 60:02d} min"


@dataclass
class DNSProgress:
    """Reporter for a run that tracks contacts 1..``last``; ``label`` names it ('dns', 'dns-window')."""

    label: str
    last: int
    enabled: bool = True
    every: float | None = None  # None: EVERY_S
    clock: Callable[[], float] = time.perf_counter
    sink: Callable[[str], None] | None = None
    started: float = field(default=0.0)
    reported: float = field(default=0.0)

    def __post_init__(self) -> None:
        self.started = self.reported = self.clock()
        if self.every is None:
            self.every = EVERY_S

    def line(self, t: float, done: int, extra: str = "") -> str:
        """'[dns] contact k/N, t = ..., elapsed ..., ETA ...' for ``done`` contacts peaked by time ``t``."""
        elapsed = self.clock() - self.started
        text = f"[{self.label}] contact {done}/{self.last}, t = {t:.4g}, elapsed {duration(elapsed)}"
        if 0 < done < self.last:
            text += f", ETA {duration(elapsed / done * (self.last - done))}"
        return text + (f" ({extra})" if extra else "")

    def update(self, t: float, done: int, extra: str = "") -> None:
        """Print a line if enabled and ``every`` seconds have passed since the last one."""
        if not self.enabled or self.clock() - self.reported < self.every:
            return
        self.reported = self.clock()
        text = self.line(t, done, extra)
        if self.sink is not None:
            self.sink(text)
        else:
            print(text, file=sys.stderr, flush=True)
