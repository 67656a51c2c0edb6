"""``pulsemap bench``: work-precision of the DNS, the baselines and the reduced models per scene."""

from __future__ import annotations

import argparse


def register(sub) -> None:
    """Add the ``bench`` sub-command to the ``pulsemap`` parser."""
    from pulsemap.solvers.cli.common import number

    p = sub.add_parser(
        "bench",
        help="error against run time: compiled and scipy DNS engines, a user's script (warm and cold), baselines, models",
        description="Work-precision per scene: the compiled DNS engine, the scipy DNS engine (moving window; "
        "DOP853, RK45, Radau, BDF, LSODA) and a careful user's vectorised scipy DOP853 script over ladders of "
        "tolerances, each also cold (first call of a fresh process, empty numba cache: JIT included), with "
        "their ratios at equal accuracy; baseline (b) the full-chain DNS, baseline (a) a "
        "loop-RHS solve_ivp script with peaks off a grid, and every reduced model (map profiles x "
        "variants, long-wave and balance laws), each against a reference DNS (tightest tolerance, "
        "convergence checked); warm-up then best of K; speed ratios at equal accuracy.",
    )
    p.add_argument("scenes", nargs="*", metavar="SCENE", default=["default"],
                   help="built-in scene names or TOML paths (default: default)")
    p.add_argument("--csv", metavar="FILE", help="one row per measured run ('-' for stdout)")
    p.add_argument("--json", metavar="FILE", help="full report ('-' for stdout)")
    p.add_argument("--plot", metavar="FILE.png", help="log-log error against time (needs matplotlib)")
    p.add_argument("--repeats", type=int, default=None, metavar="K", help="timed runs after the warm-up (3; --quick: 1)")
    p.add_argument("--quick", action="store_true", help="3 tolerances, DOP853/RK45/LSODA, one baseline (a) setting")
    p.add_argument("--target", type=number, default=1e-6, help="accuracy for the speed ratios (1e-6)")
    p.add_argument("--no-baselines", action="store_true", help="skip baselines (a) and (b)")
    p.add_argument("--no-models", action="store_true", help="skip the map and the laws")
    p.add_argument("--no-engines", action="store_true", help="skip the compiled engine and the user's script")
    p.add_argument("--no-cold", action="store_true", help="skip the cold runs (fresh processes, JIT included)")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    from pulsemap.solvers.cli.common import add_set_option

    add_set_option(p)
    p.set_defaults(func=cmd_bench)


def cmd_bench(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from pulsemap.solvers.studies.bench import BenchError, Ladder, plot, quick_ladder, run_bench, to_csv, to_text
    from pulsemap.solvers.cli.common import UsageError, progress_log, write_json, write_text
    from pulsemap.solvers.data.plotting import figures

    if args.repeats is not None and args.repeats < 1:
        raise UsageError(f"--repeats must be >= 1, got {args.repeats}")
    if not 0.0 < args.target < 1.0:
        raise UsageError(f"--target must lie in (0, 1), got {args.target:g}")
    ladder = quick_ladder() if args.quick else Ladder()
    ladder = replace(ladder, repeats=args.repeats or ladder.repeats, target=args.target,
                     baselines=not args.no_baselines, models=not args.no_models, engines=not args.no_engines,
                     cold=not args.no_cold)
    if args.plot:
        figures(BenchError)  # fail before the runs, not after
    log = progress_log(args.quiet)
    reports = run_bench(args.scenes, ladder, log, sets=args.sets)
    print(to_text(reports))
    if args.csv:
        write_text(args.csv, to_csv(reports))
    if args.json:
        write_json(args.json, {"ladder": {k: v for k, v in vars(ladder).items()}, "scenes": reports})
    if args.plot:
        plot(reports, args.plot)
    return 0
