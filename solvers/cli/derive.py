"""``pulsemap profile`` and ``pulsemap derive``: the symbolic layer's commands (no scene, no DNS)."""

from __future__ import annotations

import argparse
import time

from pulsemap.solvers.cli.common import UsageError, json_safe, number, progress_log, write_json


def register(sub) -> None:
    """Add the ``profile`` and ``derive`` sub-commands to the ``pulsemap`` parser."""
    p = sub.add_parser("profile", help="solitary-wave profile, Pade fit and universal constants")
    p.add_argument("--n", type=number, default=1.5, help="contact exponent n > 1 (default 1.5)")
    p.add_argument("--profile", default="exact", help="profile for f1..f7: exact (default) or pade")
    p.add_argument("--dps", type=int, default=None, help="mpmath working precision (digits)")
    p.add_argument("--json", metavar="OUT", help="write the report as JSON ('-' for stdout)")
    p.set_defaults(func=cmd_profile)

    p = sub.add_parser("derive", help="derive the map, long-wave law and stationary equation for R(u, v)")
    p.add_argument("expr", metavar="EXPR", help='on-site perturbation R in u, v, i and parameters, e.g. "-mu*v" '
                   '(with --model contact: the contact-law term P in d, w and parameters, e.g. "gamma*d^(1/2)*w")')
    p.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                   help="parameter value: a number, a comma list (per bead) or an expression of i; a parameter "
                        "given none stays a symbol")
    p.add_argument("--eps", type=number, default=0.1, help="small parameter eps (default 0.1)")
    p.add_argument("--n", type=number, default=1.5, help="contact exponent n > 1 (default 1.5)")
    p.add_argument("--profile", default="exact", help="exact (default) or pade")
    p.add_argument("--variant", default=None, help="map variant: paper (default), corrected, 1d")
    p.add_argument("--model", default="map", choices=("map", "energy", "momentum", "dressed", "contact"),
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
    if args.model == "contact":
        return _derive_contact(args, params, options)
    pert = check_all_used(make_perturbation(args.expr, args.eps, params, free=True))  # as pulsemap.derive
    if args.coefficients is not None and args.model != "dressed":
        raise UsageError("--coefficients applies to the dressed law only: add --model dressed or drop it")
    if args.model == "dressed":  # the law: studies/dressed.py; its coefficients: models/dressed_expansion.py
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


def _derive_contact(args: argparse.Namespace, params: dict, options: dict) -> int:
    """``pulsemap derive P --model contact``: the first-order energy law of a contact-law term P(d, w)
    (derive/contact.py), parameters without a value left symbolic."""
    from pulsemap.symbolic import printed
    from pulsemap.symbolic.contact import contact_to_json, contact_to_text, derive_contact
    from pulsemap.symbolic.contact_law import make_contact_law

    for option, given in (("--variant", args.variant), ("--fold", args.fold), ("--latex", args.latex)):
        if given:
            raise UsageError(f"{option} does not apply to the contact energy law: drop it")
    law = make_contact_law(args.expr, args.eps, params, free=True)
    numbers = {name: value for name, value in params.items() if isinstance(value, float)}
    d = derive_contact(law.monomials, n=args.n, eps=args.eps, params=numbers, profile=args.profile, dps=args.dps,
                       seconds=args.sympy_seconds)
    text, doc = contact_to_text(d, args.A0, args.i0), json_safe(contact_to_json(d, args.A0, args.i0))
    print(text)
    if args.json:
        write_json(args.json, doc)
    printed.store(options, text, doc)
    return 0


def _derive_options(args: argparse.Namespace) -> dict:
    """Every argument of ``pulsemap derive`` but --quiet and --json: what its output depends on, and what
    its validation refuses (a refused command is never stored, so it is refused again)."""
    names = ("expr", "param", "eps", "n", "profile", "variant", "model", "coefficients", "fold", "A0", "i0", "dps",
             "sympy_seconds", "max_seconds", "latex")
    return {name: getattr(args, name) for name in names}
