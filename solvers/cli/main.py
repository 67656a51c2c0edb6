"""The ``pulsemap`` command line.

Sub-commands import what they need lazily, so ``pulsemap profile`` never loads sympy or scipy.
Every error a user can cause is a one-line message on stderr and exit status 2.
"""

from __future__ import annotations

import argparse
import difflib
import importlib
import re
import sys
import time
from pathlib import Path
from typing import Callable, NoReturn, Sequence

from pulsemap.solvers.cli.common import (  # noqa: F401 (re-exported: the sub-command modules' helpers)
    SET_HELP,
    UsageError,
    add_set_option,
    call_recovering_numba_cache,
    json_safe,
    load_scene_with_sets,
    number,
    progress_log,
    stdout_document,
    text_to_stderr,
    write_json,
    write_text,
)

EXIT_USAGE = 2

# Sub-commands that live in their own module: each defines ``register(subparsers)`` and imports
# what its command needs inside the command function (so building the parser stays cheap).
COMMAND_MODULES: tuple[str, ...] = ("pulsemap.solvers.cli.sweep", "pulsemap.solvers.cli.bench", "pulsemap.solvers.cli.suite")


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
        close = difflib.get_close_matches(match.group(1), choices, n=1)
        if close:
            message += f"; did you mean '{close[0]}'?"
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


def cmd_profile(args: argparse.Namespace) -> int:
    """``pulsemap profile``: S(0), half width, Pade q's, f1..f7, Eq. 4 residual."""
    from pulsemap.symbolic.report import profile_report, profile_text

    t0 = time.perf_counter()
    report = profile_report(n=args.n, profile=args.profile, dps=args.dps)
    report["timing_s"] = round(time.perf_counter() - t0, 6)
    print(profile_text(report))
    if args.json:
        write_json(args.json, report)
    return 0


# ------------------------------------------------------------------------------ derive
def cmd_derive(args: argparse.Namespace) -> int:
    """``pulsemap derive``: expansion, map (Eq. 23), long-wave law (Eq. 30), Eq. 41; or a balance model."""
    from pulsemap.symbolic import printed

    t0 = time.perf_counter()
    options = None if args.model == "dressed" else _derive_options(args)
    hit = None if options is None else printed.load(options)
    if hit is not None and (hit[1] is not None or not args.json):  # derived before by this code: no sympy
        text, doc = hit
        print(text)
        if args.json:
            seconds = round(time.perf_counter() - t0, 6)
            write_json(args.json, {**doc, "timings_s": {"cache": seconds, "total": seconds}})
        return 0
    from pulsemap.symbolic.derivation import derive_model, to_json, to_latex, to_text
    from pulsemap.symbolic.perturbation import check_all_used, make_perturbation, parse_cli_param

    params = {}
    for text in args.param:
        name, value = parse_cli_param(text)
        if name in params:
            raise UsageError(f"--param {name} given twice")
        params[name] = value
    pert = check_all_used(make_perturbation(args.expr, args.eps, params))
    if args.coefficients is not None and args.model != "dressed":
        raise UsageError("--coefficients applies to the dressed law only: add --model dressed or drop it")
    if args.model == "dressed":  # coefficients derived by the expansion about the wave (solvers/studies/dressed.py)
        from pulsemap.solvers.studies import dressed

        dd = dressed.derive_dressed(pert, n=args.n, A0_value=args.A0, i0=args.i0, variant=args.variant,
                                    fold=args.fold, profile=args.profile, source=args.coefficients or "derived")
        print(dressed.to_latex(dd) if args.latex else dressed.to_text(dd))
        if args.json:
            write_json(args.json, dressed.to_json(dd))
        return 0
    from pulsemap.symbolic.expression import is_polynomial_in_state

    if args.model == "energy" and not is_polynomial_in_state(pert.R):  # W(A) by quadrature, as run does
        from pulsemap.solvers.api.derivation import quadrature_energy_law, quadrature_energy_text

        for option, given in (("--variant", args.variant), ("--fold", args.fold), ("--A0", args.A0),
                              ("--latex", args.latex), ("--dps", args.dps is not None)):
            if given:
                raise UsageError(f"{option} does not apply to the tabulated energy law of a non-polynomial R: drop it")
        if args.profile != "exact":
            raise UsageError("the energy law by quadrature uses the exact profile: drop --profile")
        doc = quadrature_energy_law(pert, args.n)
        print(quadrature_energy_text(doc))
        if args.json:
            write_json(args.json, doc)
        return 0
    d = derive_model(
        pert,
        args.model,
        n=args.n,
        profile=args.profile,
        variant=(args.variant or "paper") if args.model == "map" else args.variant,
        fold=args.fold,
        A0_value=args.A0,
        i0=args.i0,
        dps=args.dps,
        sympy_seconds=args.sympy_seconds,
        max_seconds=args.max_seconds,
        progress=progress_log(args.quiet),
    )
    text, doc = to_latex(d) if args.latex else to_text(d), json_safe(to_json(d)) if args.json else None
    print(text)
    if args.json:
        write_json(args.json, doc)
    printed.store(options, text, doc)  # the JSON only when asked: printing it costs up to seconds
    return 0


def _derive_options(args: argparse.Namespace) -> dict:
    """Every argument of ``pulsemap derive`` but --quiet and --json: what its output depends on, and what
    its validation refuses (a refused command is never stored, so it is refused again)."""
    names = ("expr", "param", "eps", "n", "profile", "variant", "model", "coefficients", "fold", "A0", "i0", "dps",
             "sympy_seconds", "max_seconds", "latex")
    return {name: getattr(args, name) for name in names}


# --------------------------------------------------------------------------------- run
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
        raise UsageError(why)
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


# ------------------------------------------------------------------------------- table
def cmd_table(args: argparse.Namespace) -> int:
    """``pulsemap table``: every model's errors against the DNS for the paper's scenes, and the winners."""
    from pulsemap.solvers.studies.table import markdown, table, wins

    rows = table(args.scenes or None, progress=not args.quiet, rows_file=args.rows, fresh=args.fresh, eps=args.eps,
                 sets=tuple(args.sets))
    print(markdown(rows))
    print("\nScenes won: " + ", ".join(f"{k} {v}" for k, v in wins(rows).items()))
    if args.json:
        write_json(args.json, {"rows": rows})
    return 0


# ---------------------------------------------------------------------------- generate
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
            except ValueError as exc:
                if not isinstance(src, codegen.BalanceSource):
                    raise
                print(f"no {src.model}-balance module for {name}: {exc}")  # the model is undefined for this R
                continue
            print(f"{path}  <- {name}")
    return 0


# ------------------------------------------------------------------------------- main
def build_parser() -> argparse.ArgumentParser:
    parser = _ArgumentParser(
        prog="pulsemap",
        description="Primary pulses in uncompressed granular chains with on-site perturbations "
        "(Starosvetsky's amplitude map, long-wave law, stationary shocks, checked by DNS).",
    )
    from pulsemap.solvers import __version__
    from pulsemap.solvers.data.scene.schema import METHODS

    parser.add_argument("--version", action="version", version=f"pulsemap {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    p = sub.add_parser("profile", help="solitary-wave profile, Pade fit and universal constants")
    p.add_argument("--n", type=number, default=1.5, help="contact exponent n > 1 (default 1.5)")
    p.add_argument("--profile", default="exact", help="profile for f1..f7: exact (default) or pade")
    p.add_argument("--dps", type=int, default=None, help="mpmath working precision (digits)")
    p.add_argument("--json", metavar="OUT", help="write the report as JSON ('-' for stdout)")
    p.set_defaults(func=cmd_profile)

    p = sub.add_parser("derive", help="derive the map, long-wave law and stationary equation for R(u, v)")
    p.add_argument("expr", metavar="EXPR", help='on-site perturbation R in u, v, i and parameters, e.g. "-mu*v"')
    p.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                   help="parameter value: a number, a comma list (per bead) or an expression of i")
    p.add_argument("--eps", type=number, default=0.1, help="small parameter eps (default 0.1)")
    p.add_argument("--n", type=number, default=1.5, help="contact exponent n > 1 (default 1.5)")
    p.add_argument("--profile", default="exact", help="exact (default) or pade")
    p.add_argument("--variant", default=None, help="map variant: paper (default), corrected, 1d")
    p.add_argument("--model", default="map", choices=("map", "energy", "momentum", "dressed"),
                   help="map (default: the paper's map, long-wave law, Eq. 41), energy or momentum balance, "
                        "dressed (the energy law's second order: k1, k2, cross terms and onset lag derived by the "
                        "expansion about the exact wave)")
    p.add_argument("--coefficients", default=None, choices=("derived", "calibrated"),
                   help="dressed law: k2/k1, onset lags and cross terms derived (default: the expansion about the "
                        "exact wave) or calibrated (DNS fits)")
    p.add_argument("--fold", metavar="NAME", help="locate the saddle-node of Eq. 41 in parameter NAME")
    p.add_argument("--A0", type=number, default=None, help="initial amplitude for the law's singular index")
    p.add_argument("--i0", type=number, default=0.0, help="contact index of A0 (default 0)")
    p.add_argument("--dps", type=int, default=None, help="mpmath working precision (digits)")
    p.add_argument("--sympy-seconds", type=number, default=2.0,
                   help="time bound for sympy's closed-form integration (default 2 s; a time-out is "
                        "remembered in the cache, a larger bound tries again)")
    p.add_argument("--max-seconds", type=number, default=None, metavar="S",
                   help="stop the derivation after S seconds with a message (integrals done so far stay cached)")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    p.add_argument("--latex", action="store_true", help="print LaTeX instead of text")
    p.add_argument("--json", metavar="OUT", help="write the derivation as JSON ('-' for stdout)")
    p.set_defaults(func=cmd_derive)

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
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    add_set_option(p)
    p.set_defaults(func=cmd_table)

    p = sub.add_parser("scenes", help="list the built-in scenes")
    p.set_defaults(func=cmd_scenes)

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
    """Let an expression that starts with '-' (e.g. "-mu*v", "-v") pass as a positional argument.

    A single-dash word that is no option of any command and no number is a value: a leading
    space makes argparse take it as one (the expression parser skips the space).
    """
    out = []
    for arg in argv:
        single_dash = arg.startswith("-") and not arg.startswith("--") and arg != "-"
        if single_dash and (any(c in arg for c in "*()^/+ ")
                            or (arg.split("=")[0] not in options and not _is_number(arg))):
            arg = " " + arg  # argparse treats it as a value; the parser skips the space
        out.append(arg)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    try:
        parser = build_parser()
        args = parser.parse_args(_protect_expressions(list(sys.argv[1:] if argv is None else argv),
                                                      _option_strings(parser)))
        _check_outputs(args)
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
    except (ValueError, OSError) as exc:  # our errors subclass ValueError
        message = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        if isinstance(exc, OSError):
            from pulsemap.symbolic.files import explain_os_error

            message = explain_os_error(exc)  # "[Errno 28] ..." -> the file, the reason, what to do
        print(f"pulsemap: error: {message}", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
