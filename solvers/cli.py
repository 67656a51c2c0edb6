"""The ``pulsemap`` command line.

Sub-commands import what they need lazily, so ``pulsemap profile`` never loads sympy or scipy.
Every error a user can cause is a one-line message on stderr and exit status 2.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from typing import Callable, Sequence

EXIT_USAGE = 2


class UsageError(ValueError):
    """A command-line argument that cannot be used as given."""


def _positive_float(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None


def _write_json(path: str, payload: dict) -> None:
    if path == "-":
        json.dump(payload, sys.stdout, indent=2, sort_keys=False)
        sys.stdout.write("\n")
        return
    with open(path, "w", encoding="utf-8") as fh:
        json.dump(payload, fh, indent=2, sort_keys=False)
        fh.write("\n")


# ----------------------------------------------------------------------------- profile
def cmd_profile(args: argparse.Namespace) -> int:
    """``pulsemap profile``: S(0), half width, Pade q's, f1..f7, Eq. 4 residual."""
    from derive.report import profile_report, profile_text

    t0 = time.perf_counter()
    report = profile_report(n=args.n, profile=args.profile, dps=args.dps)
    report["timing_s"] = round(time.perf_counter() - t0, 6)
    print(profile_text(report))
    if args.json:
        _write_json(args.json, report)
    return 0


# ------------------------------------------------------------------------------- main
def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="pulsemap",
        description="Primary pulses in uncompressed granular chains with on-site perturbations "
        "(Starosvetsky's amplitude map, long-wave law, stationary shocks, checked by DNS).",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    p = sub.add_parser("profile", help="solitary-wave profile, Pade fit and universal constants")
    p.add_argument("--n", type=_positive_float, default=1.5, help="contact exponent n > 1 (default 1.5)")
    p.add_argument("--profile", default="exact", help="profile for f1..f7: exact (default) or pade")
    p.add_argument("--dps", type=int, default=None, help="mpmath working precision (digits)")
    p.add_argument("--json", metavar="OUT", help="write the report as JSON ('-' for stdout)")
    p.set_defaults(func=cmd_profile)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    func: Callable[[argparse.Namespace], int] = args.func
    try:
        return func(args)
    except KeyboardInterrupt:
        print("pulsemap: interrupted", file=sys.stderr)
        return 130
    except (ValueError, OSError) as exc:  # our errors subclass ValueError
        message = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        print(f"pulsemap: error: {message}", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
