"""On-disk cache for expensive, deterministic results (integrals, kappa_n, generated code).

The location is ``$PULSEMAP_CACHE_DIR`` if set, else ``~/.cache/pulsemap``. Entries are small
JSON files keyed by a string that names everything the value depends on; a corrupt or
unreadable entry is treated as missing.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path
from typing import Any


def cache_dir() -> Path:
    """The cache directory (created on demand)."""
    root = os.environ.get("PULSEMAP_CACHE_DIR")
    path = Path(root) if root else Path.home() / ".cache" / "pulsemap"
    path.mkdir(parents=True, exist_ok=True)
    return path


def _entry_path(namespace: str, key: str) -> Path:
    digest = hashlib.sha256(key.encode()).hexdigest()[:24]
    folder = cache_dir() / namespace
    folder.mkdir(parents=True, exist_ok=True)
    return folder / f"{digest}.json"


def load(namespace: str, key: str) -> Any | None:
    """Return the cached value stored under ``key``, or None."""
    path = _entry_path(namespace, key)
    try:
        with open(path, encoding="utf-8") as fh:
            entry = json.load(fh)
    except (OSError, ValueError):
        return None
    if not isinstance(entry, dict) or entry.get("key") != key:
        return None
    return entry.get("value")


def store(namespace: str, key: str, value: Any) -> None:
    """Store a JSON-serialisable ``value`` under ``key`` (atomic rename)."""
    path = _entry_path(namespace, key)
    fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
    with os.fdopen(fd, "w", encoding="utf-8") as fh:
        json.dump({"key": key, "value": value}, fh)
    os.replace(tmp, path)
