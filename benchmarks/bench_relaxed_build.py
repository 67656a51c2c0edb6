"""Cold build of the relaxed model on the non-uniform scenes of bench_nonuniform.py: the fast GCV search
and the one-entry leave-one-run-out accuracy against scipy's make_smoothing_spline with each left-out
fit stored on its own (the code before), A/B in one process.

Run: python benchmarks/bench_relaxed_build.py [scene ...]
Per scene: the DNS once (its seed peak), then the relaxed model alone in an empty pulsemap cache,
the reference (A) and the fast path (B), in alternating order; printed: wall seconds of each (the build, the
iteration and the stated accuracy), their ratio, the build of B as ``timings_s`` reports it, and
whether A and B state the same accuracy and peaks bit for bit. numba's kernels are compiled (or
loaded) before the first timed run.
"""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_nonuniform import SCENES, scene_text  # noqa: E402


@contextlib.contextmanager
def reference():
    """scipy's make_smoothing_spline for every bulk fit and each left-out fit cached on its own."""
    from scipy.interpolate import make_smoothing_spline

    from pulsemap.solvers.models import relaxed, relaxed_table as rt

    saved = rt._smoothing_spline, rt.leave_one_out, relaxed.leave_one_out
    fit_bulk = rt.fit_bulk

    def scipy_spline(x, y, w):
        try:
            return make_smoothing_spline(x, y, w=w)
        except (np.linalg.LinAlgError, ValueError):
            return None

    def leave_one_out(table):  # a fit for every left-out run, each stored in the cache
        worst = 0.0
        for j in list(table.runs):
            others = {i: p for i, p in table.runs.items() if i != j}
            fit = fit_bulk(*table.bulk_points(others))
            xo, _ = table.bulk_points(others)
            xj, yj = table.bulk_points({j: table.runs[j]})
            if fit is None or xj.size == 0 or xo.size == 0:
                continue
            inside = (xj >= xo[0]) & (xj <= xo[-1])
            if np.any(inside):
                worst = max(worst, float(np.max(np.abs(fit(xj[inside]) - yj[inside]))))
        return worst

    rt._smoothing_spline = scipy_spline
    rt.leave_one_out = relaxed.leave_one_out = leave_one_out
    try:
        yield
    finally:
        rt._smoothing_spline, rt.leave_one_out, relaxed.leave_one_out = saved


def cold(name: str, dns: dict) -> tuple[float, dict]:
    from pulsemap.solvers.data.scene import load_scene
    from pulsemap.solvers.studies.run import run_scene

    R, eps, params = SCENES[name]
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["PULSEMAP_CACHE_DIR"] = tmp
        path = Path(tmp) / f"{name}.toml"
        path.write_text(scene_text(name, R, eps, params), encoding="utf-8")
        t0 = time.perf_counter()
        res = run_scene(load_scene(str(path)), methods=["relaxed"], reuse_dns=dns)
        return time.perf_counter() - t0, res


def main(names: list[str]) -> None:
    from pulsemap.solvers.data.scene import load_scene
    from pulsemap.solvers.studies.run import run_scene

    print(f"{'scene':24s} {'A wall s':>8s} {'B wall s':>8s} {'A/B':>5s} {'B timings_s':>11s} {'same':>5s}")
    for k, name in enumerate(names or list(SCENES)):
        R, eps, params = SCENES[name]
        with tempfile.TemporaryDirectory() as tmp:
            os.environ["PULSEMAP_CACHE_DIR"] = tmp
            path = Path(tmp) / f"{name}.toml"
            path.write_text(scene_text(name, R, eps, params), encoding="utf-8")
            dns = run_scene(load_scene(str(path)), methods=["dns"])
        if k % 2:
            wb, b = cold(name, dns)
        with reference():
            wa, a = cold(name, dns)
        if not k % 2:
            wb, b = cold(name, dns)
        same = (a["relaxed"]["bulk_accuracy_log_ratio"] == b["relaxed"]["bulk_accuracy_log_ratio"]
                and np.array_equal(np.asarray(a["peaks"]["relaxed"], float), np.asarray(b["peaks"]["relaxed"], float),
                                   equal_nan=True))
        print(f"{name:24s} {wa:8.2f} {wb:8.2f} {wa / wb:5.1f} {b['timings_s']['relaxed']:11.2f} {str(same):>5s}",
              flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
