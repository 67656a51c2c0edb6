"""What every ``pulsemap`` sub-command shares: the usage error, number arguments, ``--set``, progress
lines on stderr, and documents (JSON, CSV) written to a file or to stdout ('-') while everything
else a command prints goes to stderr."""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import stat
import sys
from typing import Callable, Sequence, TextIO

from pulsemap.symbolic.errors import PulsemapError


class UsageError(PulsemapError):
    """A command-line argument that cannot be used as given."""


def number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None


_DOCUMENT_STREAMS: list[TextIO] = []  # the real stdout while a command's text goes to stderr (--json - / --csv -)


def int_at_least(low: int, expected: str = "an integer", option: str | None = None) -> Callable[[str], int]:
    """An argparse type: an integer >= ``low`` (``option`` names the option in the error when too low)."""

    def parse(text: str) -> int:
        try:
            n = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}") from None
        if n < low:
            raise argparse.ArgumentTypeError(
                f"{option} must be >= {low}, got {n}" if option else f"expected {expected} >= {low}, got {n}")
        return n

    return parse


def _document_stream() -> TextIO:
    """Where a '-' document goes: the process's stdout, even while print() is sent to stderr."""
    return _DOCUMENT_STREAMS[-1] if _DOCUMENT_STREAMS else sys.stdout


def json_safe(obj):
    """``obj`` with every NaN or infinity replaced by None: JSON has no such numbers (strict parsers refuse them)."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    return obj


def write_json(path: str, payload: dict) -> None:
    """Write ``payload`` as strict JSON to ``path`` ('-': stdout, which then holds nothing else)."""
    write_text(path, json.dumps(json_safe(payload), indent=2, sort_keys=False, allow_nan=False) + "\n")


def write_text(path: str, text: str) -> None:
    """Write a document (JSON, CSV) to ``path`` ('-': stdout, which then holds nothing else), atomically
    for a file (the old file stays whole if the write fails); the error names the file and the fix."""
    if path == "-":
        stream = _document_stream()
        stream.write(text)
        stream.flush()
        return
    from pulsemap.symbolic.files import WriteError, describe_os_error, write_atomic

    try:
        mode = os.stat(path).st_mode
    except OSError:
        mode = None
    try:
        if mode is not None and not stat.S_ISREG(mode) and not stat.S_ISDIR(mode):
            with open(path, "w", encoding="utf-8") as fh:  # a pipe or device (/dev/stdout, >(jq)): written in place
                fh.write(text)
        else:  # a file: whole before and after (a temporary renamed over it), also on a full disk
            write_atomic(os.path.realpath(path), text)
    except OSError as exc:
        raise WriteError(describe_os_error(exc, path, "the document")) from None


def stdout_document(args: argparse.Namespace) -> bool:
    """True when --json - or --csv - asks for the document on stdout (at most one of them may)."""
    dashes = [f"--{option} -" for option in ("json", "csv") if getattr(args, option, None) == "-"]
    if len(dashes) > 1:
        raise UsageError(f"{' and '.join(dashes)} both ask for stdout: send one of them to a file")
    return bool(dashes)


def _fileno(stream) -> int | None:
    try:
        return stream.fileno()
    except (AttributeError, OSError, ValueError):  # io.UnsupportedOperation is both; captured streams have none
        return None


@contextlib.contextmanager
def text_to_stderr():
    """While a document goes to stdout, everything a command prints goes to stderr.

    print() is redirected in Python; when stdout and stderr are real files, file descriptor 1 is
    pointed at stderr too, so that output from C or Fortran code (LSODA's messages) and from worker
    processes cannot reach the document either.
    """
    out_fd, err_fd = _fileno(sys.stdout), _fileno(sys.stderr)
    document = sys.stdout
    saved = None
    if out_fd is not None and err_fd is not None:
        sys.stdout.flush()
        saved = os.dup(out_fd)
        os.dup2(err_fd, out_fd)
        document = os.fdopen(saved, "w", encoding="utf-8", closefd=False)
    _DOCUMENT_STREAMS.append(document)
    try:
        with contextlib.redirect_stdout(sys.stderr):
            yield
    finally:
        _DOCUMENT_STREAMS.pop()
        if saved is not None:
            document.flush()
            sys.stdout.flush()
            os.dup2(saved, out_fd)
            os.close(saved)


def progress_log(quiet: bool = False) -> Callable[[str], None]:
    """Progress lines to stderr, plain and flushed (they read the same in a log file); a no-op with --quiet."""
    if quiet:
        return lambda s: None
    return lambda s: print(s, file=sys.stderr, flush=True)


SET_HELP = ("change a scene key, as dotted in the scene file (repeatable): e.g. --set perturbation.eps=0.2 "
            "--set excitation.velocity=2 --set perturbation.params.mu=3")


def add_set_option(p: argparse.ArgumentParser) -> None:
    """``--set KEY=VALUE`` (repeatable) on a command that loads scenes."""
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="sets", help=SET_HELP)


def load_scene_with_sets(ref: str, sets: Sequence[str] = ()):
    """The scene ``ref`` (a file or any named scene) with the --set assignments applied (data/scene/overrides.py)."""
    from pulsemap.solvers.data.scene.overrides import with_sets
    from pulsemap.solvers.data.scene import load_scene

    return with_sets(load_scene(ref), sets)


# ----------------------------------------------------------------------------- profile
