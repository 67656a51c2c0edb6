"""On-disk cache for expensive, deterministic results (integrals, kappa_n, generated code).

The location is the user's cache directory, never the installed package: ``$PULSEMAP_CACHE_DIR``
if set, else ``$XDG_CACHE_HOME/pulsemap`` (the XDG rule; only an absolute path counts), else
``~/.cache/pulsemap``. Entries are small JSON files keyed by a string that names everything the
value depends on; an unreadable entry is treated as missing, and a damaged one (not JSON, or a
value its reader's check refuses: wrong shape, NaN) too, with a one-line note on stderr. Generated code the
shipped ``generated/`` folder lacks is written to its ``generated/`` subfolder.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import sys
import tempfile
from pathlib import Path
from typing import Any, Callable


class CacheDirError(OSError):
    """The cache directory cannot be created; the message names it and the fix."""


def cache_root() -> Path:
    """Where the cache lives (not created): $PULSEMAP_CACHE_DIR, $XDG_CACHE_HOME/pulsemap, ~/.cache/pulsemap."""
    root = os.environ.get("PULSEMAP_CACHE_DIR")
    if root:
        return Path(root).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME", "")
    if xdg and Path(xdg).is_absolute():  # the XDG spec: a relative value is invalid and ignored
        return Path(xdg) / "pulsemap"
    return Path.home() / ".cache" / "pulsemap"


def cache_dir() -> Path:
    """The cache directory (created on demand)."""
    path = cache_root()
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise CacheDirError(
            f"cannot create the cache directory {path} ({exc.strerror or exc}): "
            "set PULSEMAP_CACHE_DIR to a writable folder"
        ) from None
    return path


def _entry_path(namespace: str, key: str) -> Path:
    digest = hashlib.sha256(key.encode()).hexdigest()[:24]
    folder = cache_dir() / namespace
    folder.mkdir(parents=True, exist_ok=True)
    return folder / f"{digest}.json"


def entry_path(namespace: str, key: str) -> Path:
    """The file of the entry ``key`` in ``namespace``."""
    return _entry_path(namespace, key)


def note_damaged(namespace: str, key: str, problem: str) -> None:
    """One line on stderr: the entry is damaged and its value is being computed again."""
    print(f"pulsemap: note: cache entry {_entry_path(namespace, key)} is damaged ({problem}): computing it again",
          file=sys.stderr, flush=True)


def load(namespace: str, key: str, check: Callable[[Any], str | None] | None = None, *,
         quiet: bool = False) -> Any | None:
    """Return the cached value stored under ``key``, or None (missing, or damaged: then noted on
    stderr unless ``quiet``).

    ``check(value)`` names what is wrong with a value read back (schema, finiteness), or returns None.
    """
    path = _entry_path(namespace, key)
    try:
        with open(path, encoding="utf-8") as fh:
            entry = json.load(fh)
    except OSError:  # missing or unreadable
        return None
    except ValueError as exc:  # entries are replaced atomically: text that is not JSON is damage
        if not quiet:
            note_damaged(namespace, key, f"not JSON: {str(exc).splitlines()[0][:80]}")
        return None
    if not isinstance(entry, dict) or entry.get("key") != key:
        return None
    value = entry.get("value")
    problem = check(value) if check is not None else None
    if problem:
        if not quiet:
            note_damaged(namespace, key, problem)
        return None
    return value


def finite_number(value: Any) -> bool:
    """True for an int or float (not a bool) that is finite: what a cached number must be."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def store(namespace: str, key: str, value: Any) -> None:
    """Store a JSON-serialisable ``value`` under ``key`` (atomic rename)."""
    path = _entry_path(namespace, key)
    fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
    with os.fdopen(fd, "w", encoding="utf-8") as fh:
        json.dump({"key": key, "value": value}, fh)
    os.replace(tmp, path)
