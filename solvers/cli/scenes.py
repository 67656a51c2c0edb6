"""``pulsemap run``, ``generate``, ``table`` and ``scenes``: the commands over scenes (built-in or TOML)."""

from __future__ import annotations

import argparse

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.cli.common import (UsageError, add_set_option, int_at_least, load_scene_with_sets, number, write_json,
                                         write_text)


def register(sub) -> None:
    """Add the ``run``, ``generate``, ``table`` and ``scenes`` sub-commands to the ``pulsemap`` parser."""
    from pulsemap.solvers.data.scene.schema import METHODS

    p = sub.add_parser("run", help="run a scene: DNS, map and long-wave law side by side")
    p.add_argument("scene", metavar="SCENE", help="a TOML scene file or a built-in name (see 'pulsemap scenes')")
    p.add_argument("--methods", help=f"comma list overriding the scene's methods ({', '.join(METHODS)})")
    p.add_argument("--profile", help="exact or pade (default: the scene's, else exact)")
    p.add_argument("--variant", help="map variant: paper, corrected, 1d (default: the scene's, else paper)")
    p.add_argument("--json", metavar="OUT", help="write the result as JSON ('-' for stdout)")
    p.add_argument("--csv", metavar="OUT", help="write peaks per contact as CSV ('-' for stdout)")
    p.add_argument("--plot", metavar="OUT.png", help="plot in the paper's style (needs matplotlib)")
    p.add_argument("--log-y", action="store_true", help="--plot with a logarithmic peak axis (decaying pulses)")
    p.add_argument("--seed-peak", type=number, default=None, metavar="PEAK",
                   help="seed map and law with this peak at contact first_perturbed - 1 (default: the DNS "
                        "peak there, or v0 through kappa_n without the DNS)")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    p.add_argument("--all", action="store_true", help="print every contact (default: at most 40 rows, evenly spaced)")
    p.add_argument("--rank", action="store_true",
                   help="also rank every model against this DNS (needs dns among the methods); the best joins the "
                        "peaks, CSV, plot and JSON")
    p.add_argument("--snapshots", metavar="C1,C2,...",
                   help="contacts at whose peak time the DNS keeps the strains delta_j around the pulse (JSON)")
    add_set_option(p)
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("generate", help="write the generated modules that scenes use (default: all built-in)")
    p.add_argument("scenes", nargs="*", metavar="SCENE")
    p.add_argument("--into", metavar="DIR",
                   help="target directory (default: the user cache, $PULSEMAP_CACHE_DIR/generated; the shipped "
                        "generated/ is read-only: maintainers regenerate it with --into generated)")
    p.add_argument("--profile", help="exact or pade (default: the scene's)")
    p.add_argument("--variant", help="paper, corrected or 1d (default: the scene's)")
    p.add_argument("--dressed-tables", action="store_true",
                   help="also recompute the dressed law's shipped tables from scratch (solvers/data/dressed_derived.json "
                        "and dressed_calibration.json, for the paper's monomials; maintainers, tens of minutes)")
    p.set_defaults(func=cmd_generate)

    p = sub.add_parser("table", help="ranking: every model's errors against the DNS for the paper's scenes")
    p.add_argument("scenes", nargs="*", metavar="SCENE", help="default: all built-in scenes")
    p.add_argument("--json", metavar="OUT", help="write the rows as JSON ('-' for stdout)")
    p.add_argument("--rows", metavar="FILE.jsonl", default="pulsemap-table.jsonl",
                   help="JSON-lines file each finished scene is appended to; a rerun skips the scenes "
                        "already there (default: pulsemap-table.jsonl)")
    p.add_argument("--fresh", action="store_true", help="ignore (and replace) the rows file: recompute every scene")
    p.add_argument("--eps", type=number, default=None,
                   help="run every scene at this eps instead of its own (which model is right as eps -> 0)")
    p.add_argument("--workers", type=int_at_least(1, "a number of workers", "--workers"), default=None,
                   help="processes computing rows (default: one per core; 1 runs in this process)")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    add_set_option(p)
    p.set_defaults(func=cmd_table)

    p = sub.add_parser("scenes", help="list the built-in scenes")
    p.set_defaults(func=cmd_scenes)


def cmd_run(args: argparse.Namespace) -> int:
    """``pulsemap run SCENE``: DNS, map and long-wave peaks per contact, errors, timings."""
    from pulsemap.solvers.api.checks import run_choices
    from pulsemap.solvers.studies.ranking import add_ranking
    from pulsemap.solvers.studies.run import run_scene
    from pulsemap.solvers.studies.run.report import plot, to_csv, to_text
    from pulsemap.solvers.studies.run.report import nothing_ran

    scene = load_scene_with_sets(args.scene, args.sets)
    methods = args.methods.split(",") if args.methods is not None else None
    if methods is not None and not any(m.strip() for m in methods):
        raise UsageError(f"--methods {args.methods!r} names no method: give a comma list such as map,dns, or leave "
                         "--methods out to run the scene's methods")
    if args.rank and "dns" not in [m.strip() for m in (methods or scene.methods)]:
        raise UsageError("--rank ranks every model against the DNS: add dns to the methods")
    snapshots = _contact_list(args.snapshots, "--snapshots") if args.snapshots else ()
    methods, profile, variant, snapshots = run_choices(scene, methods, args.profile, args.variant, args.seed_peak,
                                                       snapshots)
    result = run_scene(scene, methods=methods, profile=profile, variant=variant,
                       progress=not args.quiet, seed_peak=args.seed_peak, snapshots=snapshots)
    why = nothing_ran(result)
    if why:
        from pulsemap.solvers.studies.scene_chain import out_of_range

        strong = out_of_range(scene)
        raise UsageError(f"{strong}: {why}" if strong else why)
    if args.rank:
        add_ranking(scene, result)
    print(to_text(result, every=1 if args.all else None))
    if args.json:
        write_json(args.json, result)
    if args.csv:
        write_text(args.csv, to_csv(result))
    if args.plot:
        plot(result, args.plot, log_y=args.log_y)
    return 0


def _contact_list(text: str, option: str) -> tuple[int, ...]:
    """'20,40,60' -> (20, 40, 60), a one-line usage error otherwise."""
    try:
        return tuple(int(x) for x in text.replace(" ", "").split(",") if x)
    except ValueError:
        raise UsageError(f"{option} {text!r}: give a comma list of contact numbers, e.g. 20,40,60") from None


def cmd_scenes(args: argparse.Namespace) -> int:
    """``pulsemap scenes``: the built-in scenes."""
    from pulsemap.solvers.api.scenes import scenes
    from pulsemap.solvers.data.scene import DEFAULT_SCENE, builtin_scenes, load_scene

    every, paper = scenes(), set(builtin_scenes())  # the one list pulsemap.scenes() returns
    for title, names in (("paper scenes", [n for n in every if n in paper]),
                         ("suite scenes (stiff and extreme cases)", [n for n in every if n not in paper])):
        print(f"{title}:")
        for name in names:
            sc = load_scene(name)
            mark = "  (default)" if name == DEFAULT_SCENE else ""
            print(f"  {name:16s} R = {sc.perturbation.text:28s} eps = {sc.perturbation.eps:<5g} v0 = {sc.velocity:<5g} "
                  f"contacts {sc.contacts[0]}..{sc.contacts[1]}  [{', '.join(sc.methods)}]{mark}")
    print("every name runs as it stands: pulsemap run NAME (or a .toml path)")
    return 0


def cmd_table(args: argparse.Namespace) -> int:
    """``pulsemap table``: every model's errors against the DNS for the paper's scenes, and the winners."""
    from pulsemap.solvers.studies.table import markdown, table, wins

    rows = table(args.scenes or None, progress=not args.quiet, rows_file=args.rows, fresh=args.fresh, eps=args.eps,
                 sets=tuple(args.sets), workers=args.workers)
    print(markdown(rows))
    print("\nScenes won: " + ", ".join(f"{k} {v}" for k, v in wins(rows).items()))
    if args.json:
        write_json(args.json, {"rows": rows})
    return 0


def cmd_generate(args: argparse.Namespace) -> int:
    """``pulsemap generate``: write the generated modules the given scenes use."""
    from pulsemap.symbolic import codegen
    from pulsemap.solvers.data.scene import builtin_scenes, load_scene

    names = args.scenes or builtin_scenes()
    written = set()
    for name in names:
        scene = load_scene(name)
        pert = scene.perturbation
        profile = args.profile or scene.profile
        sources = []
        if "dns" in scene.methods:
            sources.append(codegen.force_source(pert.text, pert.used_parameters))
        if "map" in scene.methods or "longwave" in scene.methods:
            sources.append(codegen.map_source(pert.text, pert.used_parameters, scene.exponent, profile,
                                              args.variant or scene.variant, pert.site_dependent))
        for model in ("energy", "momentum"):  # tiny; the ranking table (pulsemap table) uses them
            sources.append(codegen.balance_source(pert.text, pert.used_parameters, scene.exponent, profile, model,
                                                  pert.site_dependent))
        for src in sources:
            key = codegen.module_name(src)
            if key in written:
                continue
            written.add(key)
            try:  # write() builds the text before it touches the disk: a refused model writes no file
                path = codegen.write(src, args.into)  # default: the user cache, never the installed package
            except PulsemapError as exc:
                if not isinstance(src, codegen.BalanceSource):
                    raise
                print(f"no {src.model}-balance module for {name}: {exc}")  # the model is undefined for this R
                continue
            print(f"{path}  <- {name}")
    if args.dressed_tables:
        from pulsemap.solvers.models import dressed_expansion as derived
        from pulsemap.solvers.studies import dressed_calibration as calibrated

        for module, what in ((derived, "derived"), (calibrated, "calibrated")):  # no cache: every one recomputed
            print(f"{module.write_shipped()}  <- the dressed law's {what} coefficients")
    return 0
