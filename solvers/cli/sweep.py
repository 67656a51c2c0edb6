"""``pulsemap bifurcation``, ``pulsemap ensemble`` and ``pulsemap sweep``: sweeps on a process pool or a Dask cluster.

Both run their points through solvers/sweep.py: ``--workers W`` processes (1: this process),
or ``--scheduler ADDRESS`` for a running Dask scheduler (needs ``dask[distributed]``); each
finished point goes to ``--out FILE.jsonl`` at once and a rerun skips the recorded points.
"""

from __future__ import annotations

import argparse
import contextlib
import sys

from pulsemap.solvers.cli.common import int_at_least


_workers = int_at_least(1, "a number of workers", "--workers")
_positive_int = int_at_least(0)


def _floats(text: str) -> list[float]:
    from pulsemap.solvers.cli.common import UsageError

    try:
        values = [float(x) for x in text.replace(" ", "").split(",") if x]
    except ValueError:
        raise UsageError(f"--impulses {text!r}: give a comma list of velocities, e.g. 0.3,2.3") from None
    if not values:
        raise UsageError("--impulses is empty: give a comma list of velocities, e.g. 0.3,2.3")
    return values


@contextlib.contextmanager
def executor_for(args: argparse.Namespace):
    """(executor or None, max_workers) from --scheduler / --workers."""
    from pulsemap.solvers.cli.common import UsageError

    if getattr(args, "scheduler", None):
        try:
            from distributed import Client
        except ImportError:
            raise UsageError("--scheduler needs Dask: pip install 'dask[distributed]'") from None
        try:
            client = Client(args.scheduler, timeout=10)
        except (OSError, TimeoutError) as exc:
            raise UsageError(f"cannot reach the Dask scheduler at {args.scheduler}: {exc}") from None
        try:
            yield client.get_executor(), None
        finally:
            client.close()
        return
    yield None, args.workers


def _add_sweep_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--workers", type=_workers, default=None,
                   help="worker processes (default: the CPU count; 1 runs in this process)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run on a Dask cluster (e.g. tcp://host:8786) instead of a local process pool")
    p.add_argument("--out", metavar="FILE.jsonl",
                   help="record each finished point as one JSON line; a rerun skips the points recorded")
    p.add_argument("--retry-failed", action="store_true", help="rerun points recorded with an error")
    p.add_argument("--json", metavar="OUT", help="write the report as JSON ('-' for stdout)")
    p.add_argument("--plot", metavar="FIG.png", help="plot (needs matplotlib)")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    from pulsemap.solvers.cli.common import add_set_option

    add_set_option(p)


def _report(args: argparse.Namespace, report: dict, to_text, plot) -> int:
    """Print the report, and write its --json and --plot."""
    from pulsemap.solvers.cli.common import write_json

    print(to_text(report))
    if args.json:
        write_json(args.json, report)
    if args.plot:
        plot(report, args.plot)
    return 0


def cmd_bifurcation(args: argparse.Namespace) -> int:
    """``pulsemap bifurcation``: Eq. 41 branches and fold vs the DNS, thresholds."""
    from pulsemap.solvers.studies.bifurcation import bifurcation, plot, to_text
    from pulsemap.solvers.cli.common import UsageError, load_scene_with_sets
    from pulsemap.solvers.data.scene import PROFILES

    scene = load_scene_with_sets(args.scene, args.sets)
    lo, hi = args.range
    profiles = PROFILES if args.profiles is None else tuple(p for p in args.profiles.split(",") if p)
    for p in profiles:
        if p not in PROFILES:
            raise UsageError(f"--profiles: unknown profile {p!r}: choose from {', '.join(PROFILES)}")
    if not profiles:
        raise UsageError(f"--profiles is empty: give a comma list of {', '.join(PROFILES)}")
    impulses = _floats(args.impulses) if args.impulses else None
    with executor_for(args) as (ex, workers):
        report = bifurcation(
            scene, args.param, lo, hi, points=args.points, impulses=impulses, last=args.contacts,
            max_last=args.max_contacts, refine=args.refine, rtol=args.rtol, predict_points=args.predict_points,
            profiles=profiles, variant=args.variant, out=args.out, executor=ex, max_workers=workers,
            progress=not args.quiet, retry_failed=args.retry_failed, dns=not args.no_dns, relaxed=args.relaxed)
    return _report(args, report, to_text, plot)


def cmd_ensemble(args: argparse.Namespace) -> int:
    """``pulsemap ensemble``: M random realisations, map and DNS of each (the DNS and the contact and mass models for
    a scene with a contact-law term or masses), statistics per contact."""
    from pulsemap.solvers.studies.ensemble import ensemble, plot, to_text
    from pulsemap.solvers.cli.common import load_scene_with_sets
    from pulsemap.solvers.data.scene import with_overrides

    scene = load_scene_with_sets(args.scene, args.sets)
    if args.contacts:
        scene = with_overrides(scene, contacts=tuple(args.contacts))
    with executor_for(args) as (ex, workers):
        report = ensemble(scene, args.realisations, args.seed, profile=args.profile, variant=args.variant,
                          out=args.out, executor=ex, max_workers=workers, progress=not args.quiet,
                          retry_failed=args.retry_failed)
    return _report(args, report, to_text, plot)


def cmd_sweep(args: argparse.Namespace) -> int:
    """``pulsemap sweep``: a scene over a grid of values of any scene key."""
    from pulsemap.solvers.api.checks import run_choices
    from pulsemap.solvers.cli.common import load_scene_with_sets, write_json
    from pulsemap.solvers.studies.scene_sweep import scene_sweep, to_text

    scene = load_scene_with_sets(args.scene, args.sets)
    methods = [m.strip() for m in args.methods.split(",") if m.strip()] if args.methods else None
    if methods:
        methods = list(run_choices(scene, methods, None, None)[0])
    with executor_for(args) as (ex, workers):
        report = scene_sweep(scene, args.over, methods=methods, out=args.out, executor=ex, max_workers=workers,
                             progress=not args.quiet, retry_failed=args.retry_failed)
    print(to_text(report))
    if args.json:
        write_json(args.json, report)
    return 0


def register(sub) -> None:
    from pulsemap.solvers.cli.common import number

    p = sub.add_parser("sweep", help="run a scene over a grid of values of any scene key (--over KEY=A:B:K)")
    p.add_argument("scene", metavar="SCENE", help="a TOML scene file or a scene name (see 'pulsemap scenes')")
    p.add_argument("--over", action="append", default=[], required=True, metavar="KEY=A:B:K",
                   help="a dotted scene key and its values: A:B:K (K values from A to B) or v1,v2,... "
                        "(repeatable: the product grid), e.g. --over perturbation.eps=0.05:0.5:10")
    p.add_argument("--methods", help="comma list overriding the scene's methods")
    _add_sweep_options(p)
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser("bifurcation", help="stationary shocks vs a parameter: Eq. 41 branches, fold, DNS thresholds")
    p.add_argument("scene", metavar="SCENE", help="a TOML scene file or a built-in name (e.g. vdp-mu3-v2.3)")
    p.add_argument("--param", required=True, metavar="NAME", help="the scalar parameter to vary (e.g. mu)")
    p.add_argument("--range", nargs=2, type=number, required=True, metavar=("A", "B"), help="parameter range")
    p.add_argument("--points", type=_positive_int, default=13, metavar="K", help="DNS grid values in the range (default 13)")
    p.add_argument("--impulses", metavar="V0,...",
                   help="impulses v0 for the DNS (default: entry peaks 0.75x and 4x the fold's peak)")
    p.add_argument("--contacts", type=_positive_int, default=400, metavar="L",
                   help="DNS chain: last contact (default 400)")
    p.add_argument("--max-contacts", type=_positive_int, default=None, metavar="M",
                   help="longest chain for an undecided bisection probe (default 4 L)")
    p.add_argument("--refine", type=_positive_int, default=4, metavar="R", help="bisection steps on the threshold (default 4)")
    p.add_argument("--rtol", type=number, default=1e-8, help="DNS tolerance (default 1e-8)")
    p.add_argument("--profiles", metavar="P,...", help="profiles of the prediction, a comma list (default: all)")
    p.add_argument("--variant", default="1d", help="map variant for the multipliers (default 1d)")
    p.add_argument("--predict-points", type=_positive_int, default=61, metavar="P",
                   help="parameter values of the prediction (default 61)")
    p.add_argument("--no-dns", action="store_true", help="prediction only")
    p.add_argument("--relaxed", action="store_true",
                   help="also the relaxed map's fixed points, fold and thresholds (segment runs: ~10 s per value, cached)")
    _add_sweep_options(p)
    p.set_defaults(func=cmd_bifurcation)

    p = sub.add_parser("ensemble", help="random chains (Eq. 42): M realisations, map and DNS, statistics per contact "
                                        "(random masses or contact parameters: the DNS, energy-law and relaxed)")
    p.add_argument("scene", metavar="SCENE", help="a scene with a random per-bead parameter (e.g. fig13-seed1) or random "
                                                  "masses ([masses] m = {uniform = [0.9, 1.1], seed = 1})")
    p.add_argument("--realisations", type=_positive_int, required=True, metavar="M", help="number of realisations")
    p.add_argument("--seed", type=_positive_int, default=0, metavar="S", help="ensemble seed (default 0)")
    p.add_argument("--contacts", nargs=2, type=_positive_int, metavar=("FIRST", "LAST"), help="override the scene's contacts")
    p.add_argument("--profile", help="exact or pade (default: the scene's)")
    p.add_argument("--variant", help="map variant: paper, corrected, 1d (default: the scene's)")
    _add_sweep_options(p)
    p.set_defaults(func=cmd_ensemble)


if __name__ == "__main__":  # pragma: no cover
    from pulsemap.solvers.cli.main import main

    sys.exit(main())
