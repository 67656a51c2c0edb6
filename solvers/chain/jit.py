"""numba, configured once for every compiled kernel: its on-disk cache lives in the pulsemap user cache.

numba's ``cache=True`` writes next to the source file (``__pycache__`` inside the installed package)
unless ``numba.config.CACHE_DIR`` is set when the function is decorated: the cache locator is
created then and keeps its folder. Every module that defines a numba function takes ``njit``,
``prange`` and ``cfunc`` from here (tests/chain/test_jit_cache.py checks it), so the folder is set
before the first kernel exists. A folder numba was given (``NUMBA_CACHE_DIR`` or numba's own config
file) is respected; otherwise it is the ``numba`` subfolder of the pulsemap cache
(derive/cache.cache_root: ``$PULSEMAP_CACHE_DIR``, ``$XDG_CACHE_HOME/pulsemap`` or
``~/.cache/pulsemap``), or, when that folder cannot be created, one in the system's temporary folder:
never the package.
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

import numba
from numba import cfunc, njit, prange, types  # noqa: F401  (the decorators every kernel module uses)

from pulsemap.solvers.chain.compiled_aot import kernel_cache_dir

#: Seconds a cold compile of one chain kernel takes on one core, rounded (benchmarks/bench_first_run.py).
COMPILE_ESTIMATE_S = 20
_announced = False  # the compile note is printed once per process


def configure() -> Path:
    """Set numba.config.CACHE_DIR (module docstring) and return it; called once, at import."""
    path, blocked = kernel_cache_dir(numba.config.CACHE_DIR)
    if blocked is not None:
        print(f"pulsemap: note: cannot write {blocked}: numba's kernels cache to {path} "
              "(set PULSEMAP_CACHE_DIR to a writable folder)", file=sys.stderr, flush=True)
    numba.config.CACHE_DIR = str(path)
    return path


def _on_disk(kernel, sig: tuple) -> bool:
    """Whether numba's cache holds ``kernel`` for ``sig`` (its index, read without loading the code).
    numba has no public call for this; where its internals differ, True (no note printed)."""
    try:
        cache = kernel._cache
        return cache._index_key(sig, kernel.targetctx.codegen()) in cache._cache_file._load_index()
    except Exception:  # noqa: BLE001 - any numba without these internals: no note
        return True


def ready(kernel, args: tuple) -> float:
    """Compile numba dispatcher ``kernel`` for the types of ``args``, or load it from numba's cache,
    unless this process has it already; the seconds it took (0.0 when it had it). The first time in a
    process that this compiles (a cold cache), one line on stderr says so before the wait."""
    global _announced
    with warnings.catch_warnings():  # numba calls C function pointers (JitForce) 'experimental'
        warnings.filterwarnings("ignore", "First-class function type feature is experimental")
        sig = tuple(kernel.typeof_pyval(a) for a in args)
        if sig in kernel.overloads:
            return 0.0
        if not _announced and not _on_disk(kernel, sig):
            print(f"pulsemap: compiling the chain kernels, once per machine: ~{COMPILE_ESTIMATE_S} s",
                  file=sys.stderr, flush=True)
            _announced = True
        start = time.perf_counter()
        kernel.compile(sig)
        return time.perf_counter() - start


CACHE_DIR = configure()
