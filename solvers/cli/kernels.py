"""``pulsemap build-kernels``: build the ahead-of-time chain kernels now (after installing), not at a first run."""

from __future__ import annotations

import argparse


def kernel_names() -> list[str]:
    """Every ahead-of-time kernel as METHOD:FORM (chain/compiled_aot.py: a kernel per method, a module per form);
    read from the method table alone, so building the parser loads no numpy."""
    from pulsemap.solvers.chain import methods

    return [f"{method}:{form}" for method in methods.kernels() for form in methods.FORMS]


def _kernel_name(text: str) -> str:
    """argparse's type of a kernel's name: one of kernel_names() (argparse's wording for a wrong one, so the
    parser's error adds the closest name)."""
    names = kernel_names()
    if text not in names:
        raise argparse.ArgumentTypeError(f"invalid choice: '{text}' (choose from {', '.join(map(repr, names))})")
    return text


def register(sub) -> None:
    """Add the ``build-kernels`` sub-command to the ``pulsemap`` parser."""
    p = sub.add_parser(
        "build-kernels",
        help="build the DNS's compiled kernels now, once per machine (else the first run that needs one does)",
        description="Build the ahead-of-time chain kernels into the kernel cache (docs/dns.rst, 'The first run'), "
        "so that no later run waits for one; a kernel already built is kept. Without a C compiler each says so "
        "and numba's JIT kernels serve, as at a run.",
    )
    p.add_argument("kernels", nargs="*", metavar="METHOD:FORM", type=_kernel_name,
                   help=f"default: all ({', '.join(kernel_names())})")
    p.set_defaults(func=cmd_build_kernels)


def cmd_build_kernels(args: argparse.Namespace) -> int:
    """``pulsemap build-kernels``: each kernel asked for built (or found built), one line each."""
    from pulsemap.solvers.chain import compiled_aot

    for name in dict.fromkeys(args.kernels or kernel_names()):
        run, _, built = compiled_aot.load(*name.split(":"))
        state = "not built: numba's JIT kernel serves" if run is None else \
            f"built in {built:.1f} s" if built else "already built"
        print(f"{name:14s} {state}", flush=True)
    print(f"kernel cache: {compiled_aot.folder()}")
    return 0
