"""Files read and written safely: reads bounded by the bytes actually read that never block on a
FIFO, and atomic writes (a temporary file in the same folder, fsync, os.replace) that leave the old
file whole and no temporary behind on any failure, "no space left on device" included."""

from __future__ import annotations

import errno
import os
import stat
import tempfile
from pathlib import Path
from typing import BinaryIO, Iterator


class FileKindError(OSError):
    """A path that is not a regular file (a folder, a FIFO, a device, a socket); the message names it."""


class WriteError(OSError):
    """A file that could not be written; the message names it, the reason and what to do."""


class TooLargeError(OSError):
    """A file longer than its reader's limit (counted in bytes read, not by its stat size)."""


_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


def kind_of(mode: int) -> str:
    """What a file of stat mode ``mode`` is, in words ('a regular file', 'a FIFO (named pipe)', ...)."""
    return next((name for test, name in _KINDS if test(mode)), "a regular file")


def open_regular(path: str | os.PathLike) -> BinaryIO:
    """``path`` opened for reading in binary, if it is a regular file; never blocks.

    The file is opened with O_NONBLOCK (a FIFO with no writer would wait forever) and its type is
    checked on the open descriptor: FileKindError for anything but a regular file (``/dev/zero``,
    a FIFO, a folder), OSError as the system gives it otherwise (FileNotFoundError, ...).
    """
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags)
    except IsADirectoryError:
        raise FileKindError(errno.EISDIR, "is a directory, not a file", str(path)) from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise FileKindError(errno.EINVAL, f"is {kind_of(mode)}, not a regular file", str(path))
    except BaseException:
        os.close(fd)
        raise
    return os.fdopen(fd, "rb")


def read_bounded(path: str | os.PathLike, limit: int) -> bytes:
    """The bytes of regular file ``path`` (see :func:`open_regular`); TooLargeError past ``limit``
    bytes read (a file growing while read, or lying about its size, is stopped there)."""
    chunks, total = [], 0
    with open_regular(path) as fh:
        while chunk := fh.read(min(1 << 20, limit + 1 - total)):  # chunks: no buffer of ``limit`` bytes up front
            chunks.append(chunk)
            total += len(chunk)
            if total > limit:
                raise TooLargeError(errno.EFBIG, f"longer than {limit} bytes", str(path))
    return b"".join(chunks)


def bounded_lines(fh: BinaryIO, limit: int) -> Iterator[bytes | None]:
    """The lines of binary file ``fh``, each read at most ``limit`` bytes at a time: a longer line is
    skipped to its end (never held in memory) and yields None in its place."""
    while True:
        line = fh.readline(limit + 1)
        if not line:
            return
        if len(line) <= limit or line.endswith(b"\n"):
            yield line
            continue
        while line and not line.endswith(b"\n"):
            line = fh.readline(1 << 20)
        yield None


def write_atomic(path: str | os.PathLike, data: str | bytes) -> None:
    """Write ``data`` to ``path`` atomically: a temporary file in the same folder, flushed to the disk,
    then renamed over ``path`` (which is whole before and after). On any failure the temporary is
    removed and the error raised; ``path`` is untouched."""
    path = Path(path)
    raw = data.encode("utf-8") if isinstance(data, str) else data
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(raw)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


_FIXES = {errno.ENOSPC: "free some space on that disk or write elsewhere",
          errno.EDQUOT: "free some space (quota exceeded) or write elsewhere",
          errno.EEXIST: "remove or rename it, or give another path",
          errno.EACCES: "check its permissions or write elsewhere",
          errno.EPERM: "check its permissions or write elsewhere",
          errno.EROFS: "the file system is read-only: write elsewhere",
          errno.ENOENT: "check the path (create its folder first)",
          errno.EISDIR: "give a file name, not a folder",
          errno.ENOTDIR: "a part of the path is a file, not a folder: fix the path",
          errno.EINVAL: "its file system refuses the write (a /proc or /sys file?): write elsewhere"}


def describe_os_error(exc: OSError, path: str | os.PathLike, what: str) -> str:
    """One line naming the file, the system's reason and what to do, for an OSError while writing ``what``."""
    return f"cannot write {what} {path}: {exc.strerror or exc}: {_FIXES.get(exc.errno, 'check the path')}"


def explain_os_error(exc: OSError) -> str:
    """One line for an OSError from anywhere: the file it names (if any), the system's reason, what to do."""
    if not exc.strerror:  # ours, already a sentence
        return str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    where = f"{exc.filename}: " if exc.filename is not None else ""
    if getattr(exc, "filename2", None) is not None:
        where = f"{exc.filename} -> {exc.filename2}: "
    return f"{where}{exc.strerror}: {_FIXES.get(exc.errno, 'check the path and try again')}"
