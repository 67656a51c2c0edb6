"""The ``pulsemap`` command line: the parser, the dispatch to a sub-command and the exit status.

The sub-commands live in the modules of COMMAND_MODULES and import what they need lazily, so
``pulsemap profile`` never loads sympy or scipy. Every error a user can cause (a PulsemapError) is a
one-line message on stderr and exit status 2; any other exception is a bug and says so (exit status 1).
"""

from __future__ import annotations

import argparse
import importlib
import os
import re
import sys
import time
import traceback
from pathlib import Path
from typing import Callable, NoReturn, Sequence

from pulsemap.symbolic.errors import PulsemapError, closest
from pulsemap.solvers.cli.common import UsageError, stdout_document, text_to_stderr
from pulsemap.solvers.data.numba_cache import call_recovering_numba_cache

EXIT_USAGE = 2  # a PulsemapError or an OSError: what was asked cannot be done as asked
EXIT_BUG = 1  # any other exception: a bug in pulsemap (exit status 1, as Python gives an uncaught one)
TRACEBACK_ENV = "PULSEMAP_TRACEBACK"  # set to 1: a bug's message comes with its traceback

# The sub-command modules, in --help's order: each defines ``register(subparsers)`` and imports what its
# commands need inside the command functions (so building the parser stays cheap).
COMMAND_MODULES: tuple[str, ...] = ("pulsemap.solvers.cli.derive", "pulsemap.solvers.cli.scenes", "pulsemap.solvers.cli.sweep",
                                    "pulsemap.solvers.cli.bench", "pulsemap.solvers.cli.suite",
                                    "pulsemap.solvers.cli.kernels")


class _ArgumentParser(argparse.ArgumentParser):
    """argparse whose usage errors are UsageErrors (one line, exit 2 in :func:`main`).

    Sub-parsers inherit the class, so every sub-command's argument errors behave the same.
    """

    def error(self, message: str) -> NoReturn:
        raise UsageError(_usage_message(self.prog, message))


def _usage_message(prog: str, message: str) -> str:
    """argparse's message on one line, with a suggestion for a misspelt choice and a pointer to --help."""
    message = " ".join(message.split())
    match = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)", message)
    if match:
        choices = [c.strip().strip("'\"") for c in match.group(2).split(",")]
        close = closest(match.group(1), choices)
        if close:
            message += f"; did you mean '{close}'?"
    return f"{message} (see '{prog} --help')"


def _check_outputs(args: argparse.Namespace) -> None:
    """Output files (--json, --csv, --plot) must be writable places, and --plot needs matplotlib:
    fail before a long run, not after."""
    if getattr(args, "plot", None):
        from pulsemap.solvers.data.plotting import require_matplotlib

        require_matplotlib(UsageError)
    for option in ("json", "csv", "plot"):
        value = getattr(args, option, None)
        if not isinstance(value, str) or value == "-":
            continue
        path = Path(value).expanduser()
        if path.is_dir():
            raise UsageError(f"--{option} {value}: is a directory: give a file name in it")
        parent = path.parent
        if not parent.is_dir():
            raise UsageError(f"--{option} {value}: directory {parent} does not exist: create it or choose another path")


def build_parser() -> argparse.ArgumentParser:
    """The ``pulsemap`` parser: --version, and every sub-command of COMMAND_MODULES."""
    parser = _ArgumentParser(
        prog="pulsemap",
        description="Primary pulses in uncompressed granular chains with on-site perturbations "
        "(Starosvetsky's amplitude map, long-wave law, stationary shocks, checked by DNS).",
    )
    from pulsemap.solvers import __version__

    parser.add_argument("--version", action="version", version=f"pulsemap {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for modname in COMMAND_MODULES:
        importlib.import_module(modname).register(sub)
    return parser


def _option_strings(parser: argparse.ArgumentParser) -> set[str]:
    """Every option string of the parser and its sub-commands (e.g. -h, --json)."""
    found = set(parser._option_string_actions)
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                found |= _option_strings(sub)
    return found


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _protect_expressions(argv: list[str], options: set[str] = frozenset()) -> list[str]:
    """Let an expression that starts with '-' (e.g. "-mu*v", "-v", "----u") pass as a positional argument.

    A single-dash word that is no option of any command and no number is a value, as is a word of two
    or more dashes that cannot be an option's name: a leading space makes argparse take it as one (the
    expression parser skips the space).
    """
    out = []
    for arg in argv:
        single_dash = arg.startswith("-") and not arg.startswith("--") and arg != "-"
        no_option = arg.startswith("--") and arg != "--" and not re.fullmatch(r"--[A-Za-z][\w-]*(=.*)?", arg, re.S)
        if no_option or (single_dash and (any(c in arg for c in "*()^/+ ")
                                          or (arg.split("=")[0] not in options and not _is_number(arg)))):
            arg = " " + arg  # argparse treats it as a value; the parser skips the space
        out.append(arg)
    return out


#: The variables by which a user chooses the BLAS threads of numpy's and scipy's OpenBLAS (or MKL's): one set, and
#: the command leaves them alone.
BLAS_THREADS = ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def one_blas_thread(environ=os.environ) -> None:
    """One OpenBLAS thread for the command's process and the workers it starts, unless the user chose a number
    (BLAS_THREADS): set before numpy loads it. Its linear algebra is small (fits, banded solves), and an OpenBLAS
    thread pool spins as it starts (numpy's and scipy's each bundle one; docs/benchmarks.rst)."""
    if not any(name in environ for name in BLAS_THREADS):
        environ["OPENBLAS_NUM_THREADS"] = "1"


def main(argv: Sequence[str] | None = None) -> int:
    """The ``pulsemap`` command: ``argv`` (default: the process's arguments, and then the process is the command's
    own, so its BLAS threads are set: one_blas_thread)."""
    if argv is None:
        one_blas_thread()
    try:
        parser = build_parser()
        args = parser.parse_args(_protect_expressions(list(sys.argv[1:] if argv is None else argv),
                                                      _option_strings(parser)))
        _check_outputs(args)
        from pulsemap.symbolic.cache import remove_stale_temporaries

        remove_stale_temporaries(time.time())  # what killed runs left behind, a day on
        func: Callable[[argparse.Namespace], int] = args.func
        if stdout_document(args):
            with text_to_stderr():
                return call_recovering_numba_cache(func, args)
        return call_recovering_numba_cache(func, args)
    except BrokenPipeError:  # e.g. piped into `head`
        sys.stderr.close()
        return 0
    except KeyboardInterrupt:
        print("pulsemap: interrupted", file=sys.stderr)
        return 130
    except (PulsemapError, OSError) as exc:  # what was asked, or the machine (a file, the disk): the user's to fix
        message = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        if isinstance(exc, OSError):
            from pulsemap.symbolic.files import explain_os_error

            message = explain_os_error(exc)  # "[Errno 28] ..." -> the file, the reason, what to do
        print(f"pulsemap: error: {message}", file=sys.stderr)
        return EXIT_USAGE
    except Exception as exc:  # noqa: BLE001 - anything else is a bug in pulsemap, and says so
        return _internal_error(exc)


def _internal_error(exc: Exception) -> int:
    """A bug (an exception that is no PulsemapError): one line saying so, the traceback with
    TRACEBACK_ENV=1; exit status EXIT_BUG."""
    if os.environ.get(TRACEBACK_ENV, "") not in ("", "0"):
        traceback.print_exception(type(exc), exc, exc.__traceback__, file=sys.stderr)
    where = traceback.extract_tb(exc.__traceback__)[-1] if exc.__traceback__ else None
    at = f" at {Path(where.filename).name}:{where.lineno}" if where else ""
    message = str(exc).splitlines()[0] if str(exc) else ""
    print(f"pulsemap: internal error, please report: {type(exc).__name__}{at}: {message} "
          f"(set {TRACEBACK_ENV}=1 for the traceback)", file=sys.stderr)
    return EXIT_BUG


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
