"""Run a sympy computation with a wall-clock bound (sympy's integrate/solve can run for minutes).

The call runs in a forked child process; if it has not finished within the bound, the child is
killed and the caller gets ``None``. The result comes back pickled through a pipe from that
child (our own process image), never from user text.
"""

from __future__ import annotations

import multiprocessing as mp
from typing import Callable


def _child(conn, func, args):
    try:
        conn.send(("ok", func(*args)))
    except Exception as exc:  # noqa: BLE001 - reported to the parent as a failure
        conn.send(("error", f"{type(exc).__name__}: {exc}"))
    finally:
        conn.close()


def bounded(func: Callable, args: tuple, seconds: float):
    """``func(*args)`` if it finishes within ``seconds`` without raising, else None."""
    if seconds <= 0:
        return None
    try:
        ctx = mp.get_context("fork")
    except ValueError:  # no fork on this platform: run inline, unbounded
        return func(*args)
    parent, child = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child, args=(child, func, args), daemon=True)
    proc.start()
    child.close()
    try:
        if not parent.poll(seconds):
            return None
        status, payload = parent.recv()
    except (EOFError, OSError):
        return None
    finally:
        if proc.is_alive():
            proc.kill()
        proc.join(1.0)
        parent.close()
    return payload if status == "ok" else None
