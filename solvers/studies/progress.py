"""Progress of long commands on stderr: what, k of N, elapsed time and ETA.

On a terminal one updating line per job (each line replaces the one before; an item that failed
keeps its line); in a log file or a pipe (``pulsemap table 2> table.log``) one plain line each,
without terminal codes (chain/dns_progress.py: StatusLine, PULSEMAP_PROGRESS). Every line starts
with ``[what]`` and is flushed. ``--quiet`` gives a disabled reporter, which prints nothing.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Mapping

from pulsemap.solvers.chain.dns_progress import StatusLine, duration  # one format for every progress line

__all__ = ["Progress", "StatusLine", "describe", "duration"]


def _flat(value: object, prefix: str = "") -> dict[str, object]:
    """Dotted keys -> scalars (lists kept whole) of a nested point."""
    if isinstance(value, Mapping):
        out: dict[str, object] = {}
        for k, v in value.items():
            out.update(_flat(v, f"{prefix}{k}."))
        return out
    return {prefix[:-1]: value}


def _fmt(v: object) -> str:
    return f"{v:.6g}" if isinstance(v, float) else str(v)


def describe(points: list[Mapping[str, object]]) -> list[str]:
    """A label per sweep point from the values that vary across the points ('params.mu=1.5,
    velocity=2.3'), not from its hash; 'point j' when nothing varies."""
    flat = [_flat(p) for p in points]
    keys, seen = [], set()
    for k in dict.fromkeys(k for f in flat for k in f):
        column = tuple(repr(f.get(k)) for f in flat)
        if len(set(column)) > 1 and column not in seen:  # varies, and not a copy of a key already shown
            keys.append(k)
            seen.add(column)
    labels = []
    for j, f in enumerate(flat):
        text = ", ".join(f"{k.removeprefix('params.')}={_fmt(f.get(k))}" for k in keys)
        labels.append(text or f"point {j + 1}")
    return labels


@dataclass
class Progress:
    """A reporter for ``total`` items of one kind (``what``: 'table', 'suite', 'bisection', ...)."""

    what: str
    total: int
    enabled: bool = True
    sink: Callable[[str], None] | None = None  # default: the screen below (sys.stderr), flushed
    clock: Callable[[], float] = time.monotonic
    done: int = 0
    started: float = field(default=0.0)
    screen: StatusLine = field(default_factory=StatusLine)

    def __post_init__(self) -> None:
        self.started = self.clock()

    def say(self, text: str, keep: bool = False) -> None:
        """One line '[what] text' (when enabled); ``keep``: it stays on a terminal, not replaced by the next."""
        if not self.enabled:
            return
        if self.sink is not None:
            self.sink(f"[{self.what}] {text}")
        else:
            self.screen.show(f"[{self.what}] {text}", keep)

    def eta(self) -> str:
        """Elapsed time and, once an item has finished, the estimated time left."""
        elapsed = self.clock() - self.started
        text = f"elapsed {duration(elapsed)}"
        if 0 < self.done < self.total:
            text += f", ETA {duration(elapsed / self.done * (self.total - self.done))}"
        return text

    def start(self, label: str) -> None:
        """Item done+1 of total begins (so a slow item is never silent)."""
        self.say(f"{self.done + 1}/{self.total} {label} ...")

    def finish(self, label: str, status: str = "done", seconds: float | None = None) -> None:
        """An item finished: k/N, its label and status, elapsed and ETA."""
        self.done += 1
        took = f" in {duration(seconds)}" if seconds is not None else ""
        self.say(f"{self.done}/{self.total} {label}: {status}{took} ({self.eta()})",
                 keep=status not in ("done", "ok") or self.done == self.total)
