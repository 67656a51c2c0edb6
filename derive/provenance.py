"""What produced a result: the package version and the versions of the libraries that compute it.

Every output of pulsemap (run, derive and profile JSON) records :func:`provenance` next to the
choices that produced its numbers (scene, seeds, profile, variant, tolerances). Library
versions are read from a module already imported, else from the name of the installed
distribution's ``.dist-info`` folder, never by importing the library (so this stays
sympy/scipy-free) and without importlib.metadata's scan of every distribution (its fallback).
"""

from __future__ import annotations

import os
import platform
import sys
from functools import lru_cache

__all__ = ["LIBRARIES", "__version__", "provenance"]

__version__ = "0.1.0"
"""The package version (the single source; pyproject.toml states the same, a test checks it)."""

LIBRARIES = ("numpy", "scipy", "sympy", "mpmath")
"""The libraries whose versions can change the numbers."""


@lru_cache(maxsize=None)  # installed versions do not change within a process
def _version(name: str) -> str | None:
    """The installed version of library ``name``: its ``__version__`` when it is imported, else its
    ``NAME-VERSION.dist-info`` folder on sys.path (PEP 427/376 name it so), else importlib.metadata."""
    version = getattr(sys.modules.get(name), "__version__", None)
    if isinstance(version, str):
        return version
    prefix, suffix = f"{name}-", ".dist-info"
    for folder in sys.path:
        try:
            entries = os.listdir(folder or ".")
        except OSError:  # not a folder (a zip), or gone
            continue
        found = [e[len(prefix):-len(suffix)] for e in entries if e.startswith(prefix) and e.endswith(suffix)]
        if len(found) == 1:
            return found[0]
        if found:  # several versions side by side: the import system's choice, read the long way
            break
    from importlib import metadata  # an egg, a zip or an unusual layout

    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return None


def provenance() -> dict:
    """{"pulsemap": version, "python": ..., "numpy": ..., "scipy": ..., "sympy": ..., "mpmath": ...}."""
    return {"pulsemap": __version__, "python": platform.python_version(),
            **{name: _version(name) for name in LIBRARIES}}
