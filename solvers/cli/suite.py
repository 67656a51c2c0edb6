"""``pulsemap suite``: the stiff and extreme cases (solvers/suite.py) from one command."""

from __future__ import annotations

import argparse


def register(sub) -> None:
    """Add the ``suite`` sub-command to the ``pulsemap`` parser."""
    p = sub.add_parser(
        "suite",
        help="stiff and extreme cases: method chosen, time, error, status of each",
        description="Run the stiff and extreme scenes (stiff damping eps*mu = 10/100/1000, stiff "
        "foundation, v0 = 1e-6/1e6, eps = 1, n = 1.1/2.5/3, N = 10000, Van der Pol near its fold, "
        "unstable foundation) with the moving-window DNS, the map and the long-wave law; the DNS "
        "error is measured against a second run at 100x tighter rtol with the other kind of method.",
    )
    p.add_argument("scenes", nargs="*", metavar="SCENE",
                   help="suite scene names (see --list), built-in names or TOML paths (default: all)")
    p.add_argument("--list", action="store_true", help="list the suite's scenes and exit")
    p.add_argument("--no-check", action="store_true", help="skip the second (error) DNS run")
    p.add_argument("--repeats", type=int, default=1, metavar="K", help="DNS timings: best of K (1)")
    p.add_argument("--json", metavar="FILE", help="full report ('-' for stdout)")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    p.set_defaults(func=cmd_suite)


def cmd_suite(args: argparse.Namespace) -> int:
    from pulsemap.solvers.cli.common import UsageError, progress_log, write_json
    from pulsemap.solvers.studies.suite import run_suite, suite_scenes, to_text

    if args.list:
        print("\n".join(suite_scenes()))
        return 0
    if args.repeats < 1:
        raise UsageError(f"--repeats must be >= 1, got {args.repeats}")
    log = progress_log(args.quiet)
    report = run_suite(args.scenes, check=not args.no_check, repeats=args.repeats, log=log)
    print(to_text(report))
    if args.json:
        write_json(args.json, report)
    failed = [r["scene"] for r in report["cases"] if r["status"] == "FAIL"]
    return 1 if failed else 0
