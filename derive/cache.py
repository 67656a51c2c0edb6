"""On-disk cache for expensive, deterministic results (integrals, kappa_n, generated code).

The location is the user's cache directory, never the installed package: ``$PULSEMAP_CACHE_DIR``
if set, else ``$XDG_CACHE_HOME/pulsemap`` (the XDG rule; only an absolute path counts), else
``~/.cache/pulsemap``. Entries are small JSON files keyed by a string that names everything the
value depends on, each carrying the sha256 of its value's canonical JSON (content-addressed, as git
objects and ccache are): an entry whose value does not match its digest is damaged. A missing or
unreadable entry is treated as missing; a damaged one (not JSON, no or a wrong digest, or a value its
reader's check refuses: wrong shape, NaN) too, with a one-line note on stderr. A cache path that is
not a regular file (a folder, a FIFO, a device) is noted and bypassed; reads stop at
:data:`MAX_ENTRY_BYTES` bytes. Generated code the shipped ``generated/`` folder lacks is written to
its ``generated/`` subfolder (generated_path), or, when that place is taken, to a private temporary folder.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
import stat
import sys
import tempfile
from pathlib import Path
from typing import Any, Callable

from .files import FileKindError, TooLargeError, kind_of, read_bounded, write_atomic


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


MAX_ENTRY_BYTES = 64 * 1024 * 1024
"""Longest cache entry read (counted in bytes read): the largest, a relaxed table, is a few kB."""

_NOTED: set[str] = set()  # paths already noted as bypassed, so a run says it once


def _entry_path(namespace: str, key: str) -> Path:
    digest = hashlib.sha256(key.encode()).hexdigest()[:24]
    folder = cache_dir() / namespace
    folder.mkdir(parents=True, exist_ok=True)
    return folder / f"{digest}.json"


def digest(value: Any) -> str:
    """sha256 of the canonical JSON of ``value`` (sorted keys, no spaces): what an entry's value must match."""
    return hashlib.sha256(json.dumps(value, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def note_damaged(namespace: str, key: str, problem: str) -> None:
    """One line on stderr: the entry is damaged and its value is being computed again."""
    print(f"pulsemap: note: cache entry {_entry_path(namespace, key)} is damaged ({problem}): computing it again",
          file=sys.stderr, flush=True)


def _usable_entry_path(namespace: str, key: str) -> Path | None:
    """The entry's file, or None (noted once) when its namespace folder is a file or cannot be made."""
    try:
        return _entry_path(namespace, key)
    except CacheDirError:
        raise
    except OSError as exc:
        _note_bypassed(cache_root() / namespace, f"cannot be used ({exc.strerror or exc})")
        return None


def _note_bypassed(path: Path | str, problem: str) -> None:
    """One line on stderr (once per path and process): the cache cannot be used there, the run goes on."""
    if str(path) in _NOTED:
        return
    _NOTED.add(str(path))
    print(f"pulsemap: note: cache path {path} {problem}: working without it (remove it to cache there again)",
          file=sys.stderr, flush=True)


def load(namespace: str, key: str, check: Callable[[Any], str | None] | None = None, *,
         quiet: bool = False) -> Any | None:
    """Return the cached value stored under ``key``, or None (missing, or damaged: then noted on
    stderr unless ``quiet``).

    The value must match the entry's sha256 digest; then ``check(value)`` names what is wrong with a
    value read back (schema, finiteness), or returns None.
    """
    path = _usable_entry_path(namespace, key)
    if path is None:
        return None
    try:
        raw = read_bounded(path, MAX_ENTRY_BYTES)
    except FileNotFoundError:
        return None
    except FileKindError as exc:
        _note_bypassed(path, exc.strerror)
        return None
    except TooLargeError:
        if not quiet:
            note_damaged(namespace, key, f"longer than {MAX_ENTRY_BYTES} bytes")
        return None
    except OSError:  # unreadable
        return None
    try:
        entry = json.loads(raw.decode("utf-8"))
    except (ValueError, RecursionError) as exc:  # entries are replaced atomically: text that is not JSON is damage
        if not quiet:
            note_damaged(namespace, key, f"not JSON: {str(exc).splitlines()[0][:80]}")
        return None
    if not isinstance(entry, dict) or entry.get("key") != key:
        return None
    value = entry.get("value")
    if "sha256" not in entry:
        problem = "no digest of its value: written by an older pulsemap or by hand"
    elif digest(value) != entry["sha256"]:
        problem = "its value does not match its sha256 digest"
    else:
        problem = check(value) if check is not None else None
    if problem:
        if not quiet:
            note_damaged(namespace, key, problem)
        return None
    return value


def shipped_table(path: Path) -> dict:
    """A table of precomputed entries shipped with pulsemap (a JSON object by cache key); {} when it is missing, not
    JSON or not an object."""
    try:
        table = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return table if isinstance(table, dict) else {}


def load_or_shipped(namespace: str, key: str, shipped: Path) -> Any | None:
    """The entry ``key`` from the cache, else from the table shipped at ``shipped`` (None: neither has it)."""
    value = load(namespace, key)
    return value if value is not None else shipped_table(shipped).get(key)


def finite_number(value: Any) -> bool:
    """True for an int or float (not a bool) that is finite: what a cached number must be."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def store(namespace: str, key: str, value: Any) -> None:
    """Store a JSON-serialisable ``value`` under ``key`` with the digest of its value (atomic rename).

    The cache only saves time: a failure to store (no space left, a folder or FIFO where the entry
    goes) is one note on stderr and the run goes on; no temporary file is left behind.
    """
    plain = json.loads(json.dumps(value))  # tuples -> lists, number keys -> strings: as it reads back
    path = _usable_entry_path(namespace, key)
    if path is None:
        return
    try:
        mode = os.lstat(path).st_mode
    except OSError:
        mode = None
    if mode is not None and not stat.S_ISREG(mode) and not stat.S_ISLNK(mode):
        _note_bypassed(path, f"is {kind_of(mode)}, not a regular file")
        return
    try:
        write_atomic(path, json.dumps({"key": key, "value": plain, "sha256": digest(plain)}))
    except OSError as exc:
        _note_bypassed(path, f"cannot be written ({exc.strerror or exc})")


def generated_path(filename: str) -> Path:
    """Where the generated module ``filename`` is written: the cache's ``generated/`` folder, or, when that
    folder or the module's place in it is taken by something else (a file where the folder goes, a folder
    where the module goes), a fresh private temporary folder (noted once; the caller removes it after use)."""
    folder = cache_dir() / "generated"
    path = folder / filename
    try:
        folder.mkdir(exist_ok=True)
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return path
    except OSError as exc:
        _note_bypassed(folder, f"cannot be used ({exc.strerror or exc})")
        return Path(tempfile.mkdtemp(prefix="pulsemap-generated-")) / filename
    if stat.S_ISREG(mode):
        return path
    _note_bypassed(path, f"is {kind_of(mode)}, not a regular file")
    return Path(tempfile.mkdtemp(prefix="pulsemap-generated-")) / filename


STALE_AFTER_S = 24 * 3600
"""Age after which a temporary file or folder of an interrupted write (a killed process) is removed."""


_TEMPORARY = re.compile(r"\..+\.[A-Za-z0-9_]{8}\.tmp"  # files.write_atomic (tempfile.mkstemp)
                        r"|.+\.nb[ic]\.tmp\.[0-9a-f]{16}"  # numba's index and data files being written
                        r"|\.pulsemap_.+-[A-Za-z0-9_]{8}"  # compiled_aot's build folder (tempfile.mkdtemp)
                        r"|pulsemap-generated-[A-Za-z0-9_]{8}")  # generated_path's bypass folder
_TEMPORARY_DEPTH = 3  # <root>/<namespace>/<file>, <root>/numba/<folder>/<file>: nothing of ours lies deeper


def remove_stale_temporaries(now: float, age_s: float = STALE_AFTER_S) -> int:
    """Remove the temporaries of pulsemap's writers (``_TEMPORARY``) older than ``age_s`` at time ``now``:
    in the cache, down to the depth its own files lie, and the generated modules' bypass folders in the
    system's temporary folder; the number removed. Errors are ignored: the next run tries again."""
    import shutil

    def stale(path: Path) -> bool:
        try:
            return now - os.lstat(path).st_mtime >= age_s
        except OSError:
            return False

    found = [p for p in Path(tempfile.gettempdir()).glob("pulsemap-generated-*") if _TEMPORARY.fullmatch(p.name)]
    root = cache_root()
    for folder, dirs, files in os.walk(root):
        here = Path(folder)
        found += [here / name for name in files + dirs if _TEMPORARY.fullmatch(name)]
        depth = len(here.relative_to(root).parts)
        dirs[:] = [] if depth + 1 >= _TEMPORARY_DEPTH else [d for d in dirs if not _TEMPORARY.fullmatch(d)]
    removed = 0
    for path in found:
        if not stale(path):
            continue
        try:
            if path.is_dir() and not path.is_symlink():
                shutil.rmtree(path)
            else:
                path.unlink()
            removed += 1
        except OSError:
            continue
    return removed
