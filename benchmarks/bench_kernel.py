"""The compiled DNS kernels of paper Eq. 1 against a baseline commit's, side by side in one process: nanoseconds per
right-hand side evaluation and microseconds per contact, with the ratio baseline / this checkout.

Run: PULSEMAP_CACHE_DIR=... python benchmarks/bench_kernel.py [--baseline COMMIT] [--rounds R] [--methods RK45,DOP853]

The kernels are built ahead of time (solvers/chain/compiled_aot.py, dense force form) by a child process with its
own, empty caches: the baseline's from ``git archive`` of the baseline commit into a temporary folder (imported from
there), this checkout's from its own sources, so both sides are built alike. Both modules are then loaded
into this process and run on the same inputs through ``simulate`` (compiled.kernel_for answers with the kernel under
test), in interleaved rounds (baseline, new, baseline, new, ...; the best of R rounds each, so a load spike costs
both sides alike; the time is the CPU time of the kernel's calls):

* vdp-mu3-v2.3 and fig8-eps0.1 (their contacts, moving window), rtol 1e-6 and 1e-10 (atol = rtol / 100): kernel
  time / nfev, in ns per evaluation (target on vdp: <= 60);
* vdp-mu3-v2.3's chain over contacts 15..10000 at rtol 1e-6: kernel time per contact in us (target <= 5).

Each line also says whether the two kernels' peaks are the same bit for bit and their largest relative difference
(the kernels' changes keep the arithmetic: expected 0). The baseline's kernels must take this checkout's arguments
(``run(..., exps, coef, ct)``: commits since the contact table's ``ct``).
"""

from __future__ import annotations

import contextlib
import importlib.util
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import baseline
from pulsemap.solvers.chain import compiled
from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.data.scene import load_scene
from pulsemap.solvers.studies.extent import dns_span
from pulsemap.solvers.studies.scene_chain import make_force

#: The kernels before their vectorised right-hand side and fused error norm (docs/benchmarks.rst, "The kernel").
BASELINE = "3be6e1f"
REPO = baseline.REPO
METHODS = ("RK45", "DOP853")  # the explicit kernels simulate runs by name (Rodas4 only for a stiff force)
LONG = (15, 10_000)  # contacts of the per-contact line (vdp-mu3-v2.3's chain, as many beads as it needs)
#: The child that builds the baseline's modules: prints each module's path (argv: the source folder, methods).
BUILD = ("import sys\nimport pulsemap\nfrom pulsemap.solvers.chain import compiled_aot as aot\n"
         "assert pulsemap.__file__.startswith(sys.argv[1]), pulsemap.__file__\n"
         "for m in sys.argv[2:]:\n    run = aot.load(m, 'dense')[0]\n    assert run is not None, m\n"
         "    print(aot._paths(aot.module_name(m, 'dense'))[0])\n")


def modules(commit: str | None, methods: list[str], folder: Path) -> dict:
    """Ahead-of-time kernels (method -> run) built in a child process with empty caches in ``folder``: of
    ``commit``'s sources (``git archive`` into ``folder``), or of this checkout's (None)."""
    folder.mkdir(parents=True)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(folder / "numba"), "PULSEMAP_CACHE_DIR": str(folder / "cache"),
           "PYTHONDONTWRITEBYTECODE": "1"}
    src = REPO
    if commit is not None:
        src = baseline.sources(commit, folder / "src", "bench_kernel")
        env["PYTHONPATH"] = str(src.parent)
    built = subprocess.run([sys.executable, "-c", BUILD, str(src), *methods], env=env, cwd=str(folder),
                           capture_output=True, text=True)
    if built.returncode != 0:
        said = built.stderr.strip().splitlines()[-1:] or ["no output"]
        sys.exit(f"bench_kernel: building the kernels of {commit or 'this checkout'} failed ({said[0]})")
    return {m: _load(Path(p)) for m, p in zip(methods, built.stdout.split())}


def _load(path: Path):
    name = path.name.split(".")[0]
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.run


class Timed:
    """A kernel's run that adds the CPU time of its calls (this thread's: a shared machine's other jobs excluded)."""

    def __init__(self, kernel):
        self.kernel, self.cpu = kernel, 0.0

    def __call__(self, *args):
        t0 = time.thread_time()
        code = self.kernel(*args)
        self.cpu += time.thread_time() - t0
        return code


@contextlib.contextmanager
def kernel_under_test(kernel):
    """``simulate`` on the compiled engine runs ``kernel``; yields the Timed wrapper that ran it."""
    saved = compiled.kernel_for
    timed = Timed(kernel)
    compiled.kernel_for = lambda run, aot=True: (timed, 0.0, 0.0)
    try:
        yield timed
    finally:
        compiled.kernel_for = saved


def case(name: str, contacts: tuple[int, int] | None, method: str, rtol: float):
    """simulate's arguments for scene ``name`` (its own contacts unless given) on ``method`` at ``rtol``."""
    scene = load_scene(name)
    beads, span = dns_span(scene)
    if contacts is not None:
        span, beads = contacts, contacts[1] + 11
    chain = Chain(beads, scene.exponent, scene.velocity, make_force(scene, beads))
    return (chain, span), dict(window="auto", integrator=Integrator(method=method, rtol=rtol, atol=rtol * 1e-2))


def compare(kernels: dict, args: tuple, kwargs: dict, rounds: int) -> dict:
    """Interleaved rounds of ``simulate`` with each kernel: its best kernel CPU time and its result."""
    best = {k: np.inf for k in kernels}
    res = {}
    for _ in range(rounds + 1):  # the first round warms caches and is not counted
        for label, kernel in kernels.items():
            with kernel_under_test(kernel) as timed:
                r = simulate(*args, **kwargs)
            if label in res:
                best[label] = min(best[label], timed.cpu)
            res[label] = r
    return {k: (best[k], res[k]) for k in kernels}


def report(title: str, out: dict, per_contact: bool) -> None:
    (tb, rb), (tn, rn) = out["baseline"], out["new"]
    same = np.array_equal(rb.peaks, rn.peaks, equal_nan=True)
    ok = np.isfinite(rb.peaks) & np.isfinite(rn.peaks)
    diff = float(np.max(np.abs(rn.peaks[ok] - rb.peaks[ok]) / np.abs(rb.peaks[ok]))) if ok.any() else 0.0
    line = (f"  {title:34s} ns/eval baseline {tb / rb.nfev * 1e9:6.1f}  new {tn / rn.nfev * 1e9:6.1f}  "
            f"RATIO {tb / tn:5.2f}x")
    if per_contact:
        n = len(rn.peaks)
        line += f"  us/contact baseline {tb / n * 1e6:6.2f}  new {tn / n * 1e6:6.2f}"
    print(line + f"  (nfev {rb.nfev}/{rn.nfev}, peaks {'bitwise equal' if same else f'max rel diff {diff:.1e}'})",
          flush=True)


def main(argv: list[str]) -> None:
    opts, methods = baseline.options(argv, __doc__, BASELINE, 15, "methods", METHODS)
    print(f"bench_kernel: this checkout against {opts.baseline}, best of {opts.rounds} interleaved rounds; "
          f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores", flush=True)
    with tempfile.TemporaryDirectory(prefix="bench-kernel-") as tmp:
        t0 = time.perf_counter()
        base = modules(opts.baseline, methods, Path(tmp) / "baseline")
        new = modules(None, methods, Path(tmp) / "new")
        print(f"  kernels built in {time.perf_counter() - t0:.1f} s", flush=True)
        for method in methods:
            kernels = {"baseline": base[method], "new": new[method]}
            for name in ("vdp-mu3-v2.3", "fig8-eps0.1"):
                for rtol in (1e-6, 1e-10):
                    args, kwargs = case(name, None, method, rtol)
                    report(f"{method} {name} rtol {rtol:g}", compare(kernels, args, kwargs, opts.rounds), False)
            args, kwargs = case("vdp-mu3-v2.3", LONG, method, 1e-6)
            report(f"{method} vdp contacts {LONG[0]}..{LONG[1]} rtol 1e-6",
                   compare(kernels, args, kwargs, max(2, opts.rounds // 5)), True)


if __name__ == "__main__":
    main(sys.argv[1:])
