"""JSON-lines record files: one JSON object a line, each appended and flushed as soon as it is finished.

A run killed while writing leaves its last line cut short: readers skip such a line, and
:func:`open_for_append` first ends it with a newline, so the next record starts a line of its own
(the cut record is simply computed again).
"""

from __future__ import annotations

import json
import math
import os
import sys
from pathlib import Path
from typing import Any, Callable, Iterator, TextIO


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
    A line that cannot be a record we wrote -- not UTF-8, JSON that is not an object, a NaN or
    infinity anywhere, or refused by ``check(record)`` (which names the problem, or returns None)
    -- is skipped with a one-line note on stderr naming the file and the line.
    """
    p = Path(path)
    if not p.exists():
        return
    with p.open("rb") as fh:
        for lineno, raw in enumerate(fh, start=1):
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
            problem = non_finite_path(rec)
            if problem is not None:
                problem = f"{problem} is not a finite number"
            elif check is not None:
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
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.exists() and path.stat().st_size > 0:
        with path.open("rb") as fh:
            fh.seek(-1, os.SEEK_END)
            cut = fh.read(1) != b"\n"
        if cut:
            with path.open("a", encoding="utf-8") as fh:
                fh.write("\n")
    return path.open("a", encoding="utf-8")


def write_record(fh: TextIO, record: dict, sync: bool = False) -> None:
    """Write ``record`` as one compact JSON line and flush it (``sync``: to the disk, too)."""
    fh.write(json.dumps(record, separators=(",", ":")) + "\n")
    fh.flush()
    if sync:
        os.fsync(fh.fileno())


def append_record(path: str | os.PathLike, record: dict, sync: bool = True) -> None:
    """Append one record to the file at ``path`` (repairing a cut last line first) and flush it."""
    with open_for_append(path) as fh:
        write_record(fh, record, sync)
