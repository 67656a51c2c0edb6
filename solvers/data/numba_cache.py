"""numba's on-disk cache of compiled kernels: recognising and removing damaged files.

numba unpickles its index (``.nbi``) and data (``.nbc``) files and lets an error from a damaged one
through to the caller, on every run until the files are deleted. Functions decorated through
chain/jit.py mend their own entries (MendingCache); this is the net for any other cached numba
function (a generated module written by an older pulsemap): the command or sweep point runs again
after each damaged folder is cleared. They are only a cache: removing them costs one compilation.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Callable, TypeVar

T = TypeVar("T")


def numba_cache_folder(exc: BaseException) -> Path | None:
    """The folder of numba's cache files if ``exc`` was raised while numba read one of them, else None."""
    tb, folder = exc.__traceback__, None
    while tb is not None:
        if tb.tb_frame.f_code.co_filename.endswith(os.path.join("numba", "core", "caching.py")):
            f_locals = tb.tb_frame.f_locals
            path = getattr(f_locals.get("self"), "_index_path", None) or f_locals.get("path")
            if isinstance(path, (str, os.PathLike)):
                folder = Path(path).parent
        tb = tb.tb_next
    return folder


def call_recovering_numba_cache(func: Callable[..., T], *args) -> T:
    """``func(*args)``; while it fails reading a damaged numba cache file in a folder not yet cleared,
    that folder's cache files are removed with a note and ``func`` runs again (for functions numba
    caches without :class:`pulsemap.solvers.chain.jit.MendingCache`, e.g. an older generated module)."""
    cleared: set[Path] = set()
    while True:
        try:
            return func(*args)
        except Exception as exc:  # noqa: BLE001 - only numba's cache damage is handled; the rest goes on up
            folder = numba_cache_folder(exc)
            if folder is None or folder in cleared:
                raise
            remove_damaged_numba_cache(exc)
            cleared.add(folder)


def remove_damaged_numba_cache(exc: BaseException) -> bool:
    """If ``exc`` comes from a damaged numba cache file, remove that folder's cache files with a note
    on stderr and return True (the caller runs again and numba compiles anew); else False."""
    folder = numba_cache_folder(exc)
    if folder is None:
        return False
    removed = [p for pattern in ("*.nbi", "*.nbc") for p in folder.glob(pattern)]
    for path in removed:
        path.unlink(missing_ok=True)
    print(f"pulsemap: note: numba's compiled-code cache in {folder} is damaged ({type(exc).__name__}): removed "
          f"its {len(removed)} files, compiling the kernels again", file=sys.stderr, flush=True)
    return True

