"""Progress of one long DNS run on stderr: contacts k of N, simulated time, elapsed time and ETA.

One line at most every ``every`` seconds (none for a run shorter than that), flushed. On a terminal
each line replaces the one before (:class:`StatusLine`: one updating line per job); in a log file
or a pipe they are plain lines. The ETA assumes the time per contact stays what it has been since
the run started (the pulse's cost per contact is steady once it has formed).
"""

from __future__ import annotations

import os
import sys
import time
from dataclasses import dataclass, field
from typing import Callable, TextIO

from pulsemap.symbolic.errors import PulsemapError

EVERY_S = 5.0

PROGRESS_ENV = "PULSEMAP_PROGRESS"
"""How progress reaches stderr: unset or "auto" (one updating line on a terminal, plain lines
elsewhere), "lines" (plain lines everywhere) or "off" (no lines driven by the clock, the DNS's
every EVERY_S: what a command prints then does not depend on the machine's speed; the tests set it)."""

REPLACE_LAST = "\x1b[1A\x1b[2K"  # ANSI: cursor up one line, erase it (the line this reporter wrote last)


def progress_setting() -> str:
    """PULSEMAP_PROGRESS, checked: "auto", "lines" or "off"."""
    value = os.environ.get(PROGRESS_ENV, "auto").strip().lower() or "auto"
    if value not in ("auto", "lines", "off"):
        raise PulsemapError(f"{PROGRESS_ENV}={value!r}: give auto, lines or off")
    return value


@dataclass
class StatusLine:
    """Progress lines on a stream: on a terminal each replaces the one before (one updating line),
    elsewhere one plain line each. Every line ends with a newline, so whatever is printed after the
    job (its result, an error) starts on a clean line without the job having to close its line."""

    stream: TextIO | None = None  # None: sys.stderr when a line is written
    shown: bool = False  # the stream's last line is this reporter's and may be replaced

    def show(self, text: str, keep: bool = False) -> None:
        """Write ``text`` as a line, over this reporter's previous one on a terminal; ``keep``: it stays."""
        stream = self.stream if self.stream is not None else sys.stderr
        stream.write((REPLACE_LAST if self.shown else "") + text + "\n")
        stream.flush()
        self.shown = not keep and _is_terminal(stream) and progress_setting() == "auto"


def _is_terminal(stream: TextIO) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # no isatty, or a closed stream
        return False


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
    sink: Callable[[str], None] | None = None  # None: stderr, one updating line on a terminal
    started: float = field(default=0.0)
    reported: float = field(default=0.0)
    screen: StatusLine = field(default_factory=StatusLine)

    def __post_init__(self) -> None:
        self.started = self.reported = self.clock()
        if self.every is None:
            self.every = EVERY_S
        if self.sink is None and progress_setting() == "off":
            self.enabled = False  # lines driven by the clock: switched off (PROGRESS_ENV)

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
            self.screen.show(text)
