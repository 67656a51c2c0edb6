"""JSON-lines record files: one JSON object a line, each appended and flushed as soon as it is finished.

A run killed while writing leaves its last line cut short: readers skip such a line, and
:func:`open_for_append` first ends it with a newline, so the next record starts a line of its own
(the cut record is simply computed again). Each line carries the sha256 of its record's canonical
JSON (field ``sha256``): a line whose record does not match it (one digit changed) or that has none
is never served as a result; it is noted on stderr and its point computed again. Reads hold at
most :data:`MAX_LINE_BYTES` bytes of a line and refuse what is not a regular file (``/dev/full``, a FIFO).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import sys
from pathlib import Path
from typing import Any, Callable, Iterator, TextIO

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.symbolic.files import FileKindError, WriteError, bounded_lines, describe_os_error, open_regular

MAX_LINE_BYTES = 64 * 1024 * 1024
"""Longest record line read (bytes read): a record is a few kB; a longer line is skipped unread."""
DIGEST = "sha256"
"""The field of a record line holding the digest of the rest of the record."""


class RecordFileError(PulsemapError):
    """A record file that cannot be read as one (not a regular file); names the file and the fix."""


def record_digest(record: dict) -> str:
    """sha256 of the canonical JSON of ``record`` (sorted keys, no spaces), without its digest field."""
    body = {k: v for k, v in record.items() if k != DIGEST}
    return hashlib.sha256(json.dumps(body, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def encode_record(record: dict) -> str:
    """``record`` as one compact JSON line (no newline) with its digest."""
    plain = json.loads(json.dumps(record))  # tuples -> lists: the record as it reads back
    return json.dumps({**plain, DIGEST: record_digest(plain)}, separators=(",", ":"))


def non_finite_path(obj: Any, where: str = "") -> str | None:
    """The path (e.g. ``result.peaks[3]``) of the first NaN or infinity inside JSON data, or None."""
    if isinstance(obj, float):
        return None if math.isfinite(obj) else (where or "the value")
    if isinstance(obj, dict):
        items = ((f"{where}.{k}" if where else str(k), v) for k, v in obj.items())
    elif isinstance(obj, list):
        items = ((f"{where}[{j}]", v) for j, v in enumerate(obj))
    else:
        return None
    for path, value in items:
        found = non_finite_path(value, path)
        if found is not None:
            return found
    return None


def _note(path: Path, lineno: int, problem: str) -> None:
    print(f"pulsemap: note: {path}:{lineno}: {problem}: record ignored (its point is computed again)",
          file=sys.stderr, flush=True)


def read_lines(path: str | os.PathLike, check: Callable[[dict], str | None] | None = None) -> Iterator[dict]:
    """The JSON objects of a JSON-lines file in order (none for a missing file).

    Blank lines and lines that are not complete JSON (cut short by a kill) are skipped silently.
    A line that cannot be a record we wrote -- not UTF-8, JSON that is not an object, no digest or
    one its record does not match, a NaN or infinity anywhere, or refused by ``check(record)``
    (which names the problem, or returns None) -- is skipped with a one-line note on stderr naming
    the file and the line, as is a line longer than MAX_LINE_BYTES. RecordFileError for a path that
    is not a regular file.
    """
    p = Path(path)
    try:
        fh = open_regular(p)
    except FileNotFoundError:
        return
    except FileKindError as exc:
        raise RecordFileError(f"record file {p} {exc.strerror}: give the path of a file (JSON lines)") from None
    with fh:
        for lineno, raw in enumerate(bounded_lines(fh, MAX_LINE_BYTES), start=1):
            if raw is None:
                _note(p, lineno, f"longer than {MAX_LINE_BYTES} bytes")
                continue
            raw = raw.strip()
            if not raw:
                continue
            try:
                line = raw.decode("utf-8")
            except UnicodeDecodeError as exc:
                _note(p, lineno, f"not UTF-8 text (byte {exc.start + 1} of the line)")
                continue
            try:
                rec = json.loads(line)
            except RecursionError:
                _note(p, lineno, "JSON nested too deep")
                continue
            except ValueError:
                continue
            if not isinstance(rec, dict):
                _note(p, lineno, f"a JSON {type(rec).__name__}, not a record (an object)")
                continue
            problem = None
            if DIGEST not in rec:
                problem = "no digest: not written by this pulsemap"
            elif rec.pop(DIGEST) != record_digest(rec):
                problem = "the record does not match its sha256 digest (the line was changed)"
            if problem is None:
                problem = non_finite_path(rec)
                problem = None if problem is None else f"{problem} is not a finite number"
            if problem is None and check is not None:
                problem = check(rec)
            if problem:
                _note(p, lineno, problem)
                continue
            yield rec


def read_keyed(path: str | os.PathLike, required: tuple[str, ...] = (),
               check: Callable[[dict], str | None] | None = None) -> dict[str, dict]:
    """Records by their string ``key`` field (the last record of a key wins); records without
    one of the ``required`` fields are skipped, records ``check`` refuses are noted and skipped."""
    return {rec["key"]: rec for rec in read_lines(path, check)
            if isinstance(rec.get("key"), str) and all(k in rec for k in required)}


def open_for_append(path: str | os.PathLike) -> TextIO:
    """Open ``path`` (and its folder) for appending; end a line cut short by a killed run first."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        if path.exists() and path.stat().st_size > 0:
            with path.open("rb") as fh:
                fh.seek(-1, os.SEEK_END)
                cut = fh.read(1) != b"\n"
            if cut:
                with path.open("a", encoding="utf-8") as fh:
                    fh.write("\n")
        return path.open("a", encoding="utf-8")
    except OSError as exc:  # the system's reason alone names no file ("Invalid argument" for /proc/version)
        raise WriteError(describe_os_error(exc, path, "the records file")) from None


def write_record(fh: TextIO, record: dict, sync: bool = False) -> None:
    """Write ``record`` as one compact JSON line and flush it (``sync``: to the disk, too)."""
    fh.write(encode_record(record) + "\n")
    fh.flush()
    if sync:
        os.fsync(fh.fileno())


def append_record(path: str | os.PathLike, record: dict, sync: bool = True) -> None:
    """Append one record to the file at ``path`` (repairing a cut last line first) and flush it."""
    with open_for_append(path) as fh:
        write_record(fh, record, sync)
