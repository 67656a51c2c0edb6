"""JSON-lines record files: one JSON object a line, each appended and flushed as soon as it is finished.

A run killed while writing leaves its last line cut short: readers skip such a line, and
:func:`open_for_append` first ends it with a newline, so the next record starts a line of its own
(the cut record is simply computed again).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Iterator, TextIO


def read_lines(path: str | os.PathLike) -> Iterator[dict]:
    """The JSON objects of a JSON-lines file in order (none for a missing file); blank lines, lines
    that are not complete JSON (cut short by a kill) and lines that are not objects are skipped."""
    p = Path(path)
    if not p.exists():
        return
    with p.open(encoding="utf-8") as fh:
        for line in fh:
            line = line.strip()
            if not line:
                continue
            try:
                rec = json.loads(line)
            except ValueError:
                continue
            if isinstance(rec, dict):
                yield rec


def read_keyed(path: str | os.PathLike, required: tuple[str, ...] = ()) -> dict[str, dict]:
    """Records by their string ``key`` field (the last record of a key wins); records without
    one of the ``required`` fields are skipped."""
    return {rec["key"]: rec for rec in read_lines(path)
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
