"""What the benchmarks that measure against a baseline commit share: that commit's sources, importable as pulsemap.

Imported by benchmarks/bench_kernel.py and bench_relaxed_cold.py (run from this folder, which Python puts first on
the path).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def sources(commit: str, folder: Path, script: str) -> Path:
    """``commit``'s sources (``git archive``) as an importable pulsemap package under ``folder``, whose parent goes
    on PYTHONPATH; ``script`` names the benchmark in the message when git cannot archive the commit."""
    src = folder / "pulsemap"
    src.mkdir(parents=True)
    archive = subprocess.run(["git", "-C", str(REPO), "archive", "--format=tar", commit], capture_output=True)
    if archive.returncode != 0:
        sys.exit(f"{script}: git cannot archive {commit!r} ({archive.stderr.decode().strip()}): run it from a git "
                 "checkout that has the commit, or give another --baseline")
    subprocess.run(["tar", "-x", "-C", str(src)], input=archive.stdout, check=True)
    (src / "symbolic").symlink_to("derive")  # pyproject's package-dir: pulsemap.symbolic is derive/
    return src


def options(argv: list[str], doc: str, commit: str, rounds: int, name: str, choices) -> tuple[argparse.Namespace, list]:
    """The command line of a benchmark against a baseline commit: ``--baseline`` (default ``commit``), ``--rounds``
    and ``--NAME``, a comma list of ``choices`` (default: all); the options and the choices picked."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--baseline", default=commit)
    parser.add_argument("--rounds", type=int, default=rounds)
    parser.add_argument(f"--{name}", default=",".join(choices))
    opts = parser.parse_args(argv)
    picked = getattr(opts, name).split(",")
    unknown = [c for c in picked if c not in choices]
    if unknown:
        parser.error(f"--{name}: {', '.join(unknown)} not benchmarked here; choose from {', '.join(choices)}")
    return opts, picked
