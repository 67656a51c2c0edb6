"""Worker processes forked from this one, for the cold paths that can use a second core: forked workers
inherit what this process has loaded (the chain kernels, derived models, parsed scenes), so they start
at once and compute the same numbers as this process would."""

from __future__ import annotations

import multiprocessing
import os
import sys
import threading
from concurrent.futures import ProcessPoolExecutor


def cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def fork_pool(workers: int) -> ProcessPoolExecutor | None:
    """A pool of ``workers`` forked processes, or None where there is no safe fork: off Linux (macOS's system
    libraries may crash a forked child; Windows has no fork), or other threads running here (a fork copies
    them mid-operation, locks held)."""
    if workers < 1 or not sys.platform.startswith("linux") or threading.active_count() > 1:
        return None
    return ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("fork"))
