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
from numba import prange, types  # noqa: F401  (what every kernel module takes from here)
from numba.core.caching import FunctionCache
from numba.core.ccallback import CFunc

from pulsemap.solvers.chain.compiled_aot import kernel_cache_dir

#: Seconds a cold compile of one chain kernel takes on one core, rounded (benchmarks/bench_first_run.py).
COMPILE_ESTIMATE_S = 20
_announced = False  # the compile note is printed once per process
_noted: set = set()  # cache folders whose damage this process has reported (one note per folder)


def configure() -> Path:
    """Set numba.config.CACHE_DIR (module docstring) and return it; called once, at import."""
    path, blocked = kernel_cache_dir(numba.config.CACHE_DIR)
    if blocked is not None:
        print(f"pulsemap: note: cannot write {blocked}: numba's kernels cache to {path} "
              "(set PULSEMAP_CACHE_DIR to a writable folder)", file=sys.stderr, flush=True)
    numba.config.CACHE_DIR = str(path)
    return path


class MendingCache(FunctionCache):
    """numba's on-disk cache of one function, which treats a damaged or unreadable entry (random bytes,
    an emptied or truncated ``.nbi``/``.nbc``) as a miss: the entry's files are removed with a note and
    the function is compiled anew, however many entries are damaged; numba's own raises on every run."""

    def load_overload(self, sig, target_context):
        try:
            return super().load_overload(sig, target_context)
        except Exception as exc:  # noqa: BLE001 - any failure to read a cache file: compile anew
            _discard_entry(Path(self._cache_file._index_path), exc)
            return None

    def save_overload(self, sig, data):
        try:
            super().save_overload(sig, data)
        except Exception as exc:  # noqa: BLE001 - an entry that cannot be written: the kernel serves from memory
            _discard_entry(Path(self._cache_file._index_path), exc, writing=True)


def _discard_entry(index: Path, exc: BaseException, writing: bool = False) -> None:
    """One numba cache entry (its index file ``index`` and the data files it names) that could not be read
    (or, ``writing``, written) because of ``exc``: its files removed, with one note per folder per process
    (numba compiles the function anew and writes a fresh entry)."""
    for path in [index, *index.parent.glob(f"{index.stem}.*.nbc")]:
        try:
            path.unlink(missing_ok=True)
        except OSError:  # not ours to remove: numba compiles in memory and tries to write again
            break
    if index.parent in _noted:
        return
    _noted.add(index.parent)
    what = ("cannot be written ({}): the kernels compiled now serve this run only" if writing else
            "is damaged ({}): each damaged entry is removed and its kernel compiled again")
    print(f"pulsemap: note: numba's compiled-code cache in {index.parent} "
          + what.format(f"{type(exc).__name__} at {index.stem}"), file=sys.stderr, flush=True)


class _MendingCFunc(CFunc):
    """numba's C callback with a :class:`MendingCache`."""

    def enable_caching(self):
        self._cache = MendingCache(self._pyfunc)


def njit(*args, **options):
    """numba.njit, with a :class:`MendingCache` when ``cache=True``."""
    if args and callable(args[0]):
        return njit(*args[1:], **options)(args[0])
    cache = options.pop("cache", False)
    decorate = numba.njit(*args, **options)

    def wrapper(func):
        dispatcher = decorate(func)
        if cache:
            dispatcher._cache = MendingCache(dispatcher.py_func)
        return dispatcher

    return wrapper


def cfunc(sig, cache: bool = False, **options):
    """numba.cfunc (compiled when decorated), with a :class:`MendingCache` when ``cache=True``."""
    sig = numba.core.sigutils.normalize_signature(sig)

    def wrapper(func):
        made = _MendingCFunc(func, sig, locals=dict(options.pop("locals", {})), options=options)
        if cache:
            made.enable_caching()
        made.compile()
        return made

    return wrapper


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
