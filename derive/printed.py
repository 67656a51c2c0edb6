"""A derivation's printed forms (its text or LaTeX report and its JSON) cached by what produced them.

A warm ``pulsemap derive`` of the same input reads them back without importing sympy. The key names
the command's options, the provenance (pulsemap, Python, sympy, mpmath, numpy, scipy versions) and
the sha256 of every source file of this package (derive/), so any change to the code that derives
or prints gives a new key. The entry's digest is checked on read (derive/cache.py).
"""

from __future__ import annotations

import hashlib
import json
from functools import lru_cache
from pathlib import Path
from typing import Any

from . import cache
from .provenance import provenance

NAMESPACE = "derivation"


@lru_cache(maxsize=None)  # the sources do not change within a process
def code_digest() -> str:
    """sha256 over the relative path and bytes of every .py file of the symbolic package."""
    root = Path(__file__).resolve().parent
    h = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        h.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()


def key(options: dict) -> str:
    """The entry's key: the options (JSON-serialisable values), the provenance and the code digest."""
    return json.dumps({"options": options, "provenance": provenance(), "code": code_digest()}, sort_keys=True)


def _check(value: Any) -> str | None:
    ok = (isinstance(value, dict) and isinstance(value.get("printed"), str)
          and (value.get("json") is None or isinstance(value.get("json"), dict)))
    if not ok:
        return "not a {'printed': text, 'json': document or null} entry"
    control = next((c for c in value["printed"] if not c.isprintable() and c != "\n"), None)
    return None if control is None else f"its text holds the control character {control!r}, which this code never prints"


def load(options: dict) -> tuple[str, dict | None] | None:
    """(printed report, JSON document or None: not stored) stored for ``options``, or None."""
    hit = cache.load(NAMESPACE, key(options), _check)
    return None if hit is None else (hit["printed"], hit["json"])


def store(options: dict, printed: str, document: dict | None) -> None:
    """Store the printed report and the JSON document (None: not asked for) for ``options``."""
    cache.store(NAMESPACE, key(options), {"printed": printed, "json": document})
