"""What produced a result: the package version and the versions of the libraries that compute it.

Every output of pulsemap (run, derive and profile JSON) records :func:`provenance` next to the
choices that produced its numbers (scene, seeds, profile, variant, tolerances). Library
versions are read from the installed distributions' metadata, never by importing them, so
this stays cheap and sympy/scipy-free.
"""

from __future__ import annotations

import platform
from functools import lru_cache
from importlib import metadata

__all__ = ["LIBRARIES", "__version__", "provenance"]

__version__ = "0.1.0"
"""The package version (the single source; pyproject.toml states the same, a test checks it)."""

LIBRARIES = ("numpy", "scipy", "sympy", "mpmath")
"""The libraries whose versions can change the numbers."""


@lru_cache(maxsize=None)  # installed versions do not change within a process (0.4 ms a read)
def _version(name: str) -> str | None:
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return None


def provenance() -> dict:
    """{"pulsemap": version, "python": ..., "numpy": ..., "scipy": ..., "sympy": ..., "mpmath": ...}."""
    return {"pulsemap": __version__, "python": platform.python_version(),
            **{name: _version(name) for name in LIBRARIES}}
