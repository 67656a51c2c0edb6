"""What the first-use benchmarks share: a process started as on a new machine, and its CPU time.

Imported by benchmarks/bench_first_run_default.py, bench_first_table.py, bench_first_run.py and
bench_run_overhead.py (run from this folder, which Python puts first on the path).
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import time
from pathlib import Path
from typing import Callable

EXE = str(Path(sys.executable).with_name("pulsemap"))


def new_machine_env(folder: Path, base: dict | None = None) -> dict:
    """``base`` (default: this process's environment) with every cache a new machine lacks empty, in ``folder``:
    the pulsemap cache (scene records, generated modules, the ahead-of-time kernels and their C runtime), numba's
    cache and the user cache, whatever PULSEMAP_* and NUMBA_* it sets (they are dropped). Python's bytecode
    stays: an installed package has it."""
    env = {k: v for k, v in (os.environ if base is None else base).items() if not k.startswith(("NUMBA_", "PULSEMAP_"))}
    env.update(PULSEMAP_CACHE_DIR=str(folder / "pulsemap"), NUMBA_CACHE_DIR=str(folder / "numba"),
               XDG_CACHE_HOME=str(folder / "xdg"))
    return env


def emptied(env: dict) -> dict:
    """``env`` (new_machine_env's) with its cache folders removed: the next process starts as on a new machine."""
    for key in ("PULSEMAP_CACHE_DIR", "NUMBA_CACHE_DIR", "XDG_CACHE_HOME"):
        shutil.rmtree(env[key], ignore_errors=True)
    return env


def kernels_built(env: dict) -> int:
    """How many ahead-of-time kernel modules the kernel cache of ``env`` (new_machine_env's) holds."""
    suffix = sysconfig.get_config_var("EXT_SUFFIX") or ".so"
    return len(list((Path(env["NUMBA_CACHE_DIR"]) / "aot").glob(f"pulsemap_*{suffix}")))


def installed_kernels() -> int:
    """How many of the kernels a non-editable install builds (setup.py: compiled_aot.INSTALL_KERNELS) the installed
    package holds for this machine and these versions: a cold process takes those and builds none."""
    from pulsemap.solvers.chain import compiled_aot as aot

    names = (aot._paths(aot.module_name(m, f))[0].name for m, f in aot.INSTALL_KERNELS)
    return sum(aot._intact(aot.installed_folder() / name) for name in names)


def process(argv: list[str], env: dict) -> tuple[float, float]:
    """(wall seconds, CPU seconds) of the process ``argv``: user + system time of it and every process it waited
    for (the kernel's build in a child, the C compiler)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(argv, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime


def first_use(argv: list[str], folder: Path, target_s: float, repeat: int, what: str) -> float:
    """Measure ``argv`` as a new machine's first command (best CPU of ``repeat`` processes, each from emptied
    caches), then warm, then with only the kernels kept from a cold process (as built ahead, at install);
    print each with the kernels the cold processes built, and the ratio CPU / ``target_s``; return it."""
    env = new_machine_env(folder)
    cold, built = [], []
    for _ in range(repeat):
        cold.append(process(argv, emptied(env)))
        built.append(kernels_built(env))
    aot = Path(env["NUMBA_CACHE_DIR"]) / "aot"
    warm = min((process(argv, env) for _ in range(repeat)), key=lambda r: r[1])
    kept = folder / "kernels-kept"
    shutil.rmtree(kept, ignore_errors=True)
    ahead = []
    if aot.is_dir():  # none without a C compiler: numba's JIT kernels ran
        shutil.copytree(aot, kept)
        for _ in range(repeat):
            shutil.copytree(kept, Path(emptied(env)["NUMBA_CACHE_DIR"]) / "aot")
            ahead.append(process(argv, env))
    wall, cpu = min(cold, key=lambda r: r[1])
    print(f"{what}, {repeat} process(es) each, best CPU (the process and its children: kernel build, C compiler)")
    print(f"  kernels built at install, in the package: {installed_kernels()} (pip install .; none for an editable "
          "install, whose cold row builds its kernel)")
    print(f"  cold (every cache empty)       CPU {cpu:7.2f} s  wall {wall:7.2f} s  kernels built: {built}")
    print(f"  warm                           CPU {warm[1]:7.2f} s  wall {warm[0]:7.2f} s")
    if ahead:
        best = min(ahead, key=lambda r: r[1])
        print(f"  kernels built ahead, rest cold CPU {best[1]:7.2f} s  wall {best[0]:7.2f} s")
    ratio = cpu / target_s
    print(f"ratio: first {what} CPU / {target_s:g} s target = {ratio:.2f} ({'met' if ratio <= 1 else 'NOT met'})")
    return ratio


def main(doc: str, argv_in: Callable[[Path], list[str]], target_s: float, what: str) -> None:
    """A first-use benchmark's command line (``--repeat N``): :func:`first_use` of ``argv_in(folder)`` in a
    temporary folder."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="processes per figure (best CPU taken; default 3)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-first-use-") as tmp:
        first_use(argv_in(Path(tmp)), Path(tmp), target_s, args.repeat, what)
