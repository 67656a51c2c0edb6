"""The relaxed model on non-uniform foundations against the DNS: the per-scene table of docs/nonuniform.rst.

Run: python benchmarks/bench_nonuniform.py [--local | --first-order] [NAME-PART ...]
Each scene (n = 1.5, v0 = 1, 140 beads, beads 1..15 unperturbed, DNS at rtol 1e-10) is run with
methods dns, relaxed and map, in an empty pulsemap cache: printed per scene the live range, the
RMS and max relative error of the relaxed model and of the paper's map over it (a contact without
a value counts 100 %, as in `pulsemap run`), the relaxed model's cold build time (segment and
kernel runs and its stated accuracy, the leave-one-run-out fits; ``timings_s``), the wall time of a
cold run of the relaxed model alone and its segment runs. ``--local``: the relaxed model
with each step at its own bead's coefficient only (no kernels), for comparison; ``--first-order``: without the
bulk's second-order term. NAME-PART: only the scenes whose name holds one of them.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

GRADED = "-(a + b*(i - 16))*u"
MODULATED = "-(a + b*sin(1.2566370614359172*i))*u"  # period 5 beads
RISING, FALLING = {"a": "0.1", "b": "0.00865"}, {"a": "1.0", "b": "-0.00865"}
SCENES = {
    "graded-rising-eps0.1": (GRADED, 0.1, RISING),
    "graded-rising-eps0.5": (GRADED, 0.5, RISING),
    "graded-falling-eps0.1": (GRADED, 0.1, FALLING),
    "graded-falling-eps0.5": (GRADED, 0.5, FALLING),
    "modulated-eps0.1": (MODULATED, 0.1, {"a": "0.5", "b": "0.4"}),
    "modulated-eps0.5": (MODULATED, 0.5, {"a": "0.5", "b": "0.4"}),
    **{f"weak-random-seed{s}": ("-k*u", 1.0, {"k": f"{{uniform = [0, 0.2], seed = {s}}}"}) for s in (1, 2, 3)},
    "mixed-weak-random": ("-(k*u + mu*v)", 1.0, {"k": "{uniform = [0, 0.2], seed = 5}", "mu": "0.05"}),
    "mixed-graded-eps0.5": ("-(k*u + mu*v)", 0.5, {"k": '"0.1 + 0.00865*(i - 16)"', "mu": "0.1"}),
    **{f"strong-random-seed{s}": ("-k*u", 1.0, {"k": f"{{uniform = [0, 1], seed = {s}}}"}) for s in (1, 2, 3, 4)},
    **{f"two-valued-5to1-seed{s}": ("-k*u", 1.0, {"k": f"two-valued 0.05 0.25 {s}"}) for s in (1, 2, 4)},
    "two-valued-2to1-seed1": ("-k*u", 1.0, {"k": "two-valued 0.1 0.2 1"}),
    **{f"heavy-tailed-seed{s}": ("-k*u", 1.0, {"k": f"pareto 0.05 2.5 {s}"}) for s in (1, 2)},
    "coulomb-random-eps0.05": ("-mu*sign(v)", 0.05, {"mu": "{uniform = [0.5, 1.5], seed = 7}"}),
    "coulomb-graded-eps0.05": ("-mu*sign(v)", 0.05, {"mu": '"0.5 + 0.05*(i - 16)"'}),
    "coulomb-random-eps0.02": ("-mu*sign(v)", 0.02, {"mu": "{uniform = [0.5, 1.5], seed = 7}"}),
    "coulomb-graded-eps0.02": ("-mu*sign(v)", 0.02, {"mu": '"0.5 + 0.05*(i - 16)"'}),
    "drag-random-eps0.3": ("-mu*v*abs(v)", 0.3, {"mu": "{uniform = [0.2, 1.8], seed = 5}"}),
}
BEADS = 140


def per_bead(value: str) -> str:
    """A scene's parameter text: ``two-valued LOW HIGH SEED`` (each bead LOW or HIGH with probability 1/2) and
    ``pareto SCALE SHAPE SEED`` (SCALE (1 + a Lomax draw of SHAPE): heavy-tailed) as per-bead lists; else as given."""
    import numpy as np

    kind, *args = value.split()
    if kind == "two-valued":
        k = np.random.default_rng(int(args[2])).choice([float(args[0]), float(args[1])], size=BEADS)
    elif kind == "pareto":
        k = float(args[0]) * (1.0 + np.random.default_rng(int(args[2])).pareto(float(args[1]), size=BEADS))
    else:
        return value
    return "[" + ", ".join(repr(float(x)) for x in k) + "]"


def scene_text(name: str, R: str, eps: float, params: dict[str, str]) -> str:
    lines = [f'name = "{name}"', "[chain]", f"beads = {BEADS}", "exponent = 1.5", "first_perturbed = 16",
             "[excitation]", "velocity = 1.0", "[perturbation]", f'R = "{R}"', f"eps = {eps}",
             "[perturbation.params]", *(f"{k} = {per_bead(v)}" for k, v in params.items()), "[output]",
             "contacts = [16, 120]", 'methods = ["dns", "relaxed", "map"]']
    return "\n".join(lines) + "\n"


def main(local: bool, first_order: bool, parts: list[str]) -> None:
    from pulsemap.solvers.data.scene import load_scene
    from pulsemap.solvers.models import relaxed
    from pulsemap.solvers.studies.run import run_scene

    if first_order:
        relaxed.RelaxedModel.second_order_term = lambda self, contact, peak: 0.0
    if local:
        relaxed.RelaxedModel.mix = lambda self, c, p: [(1.0, None if self.coefficients is None else self._coef(c))]
        relaxed.RelaxedModel.onset_log_ratio = lambda self, k, s, p: self._log_onset(
            None if self.coefficients is None else self._coef(s + k), p, k)
    print(f"{'scene':24s} {'live':>8s} {'relaxed RMS':>11s} {'max':>7s} {'map RMS':>8s} {'max':>7s} {'build s':>7s}"
          f" {'wall s':>7s} {'runs':>5s}")
    for name, (R, eps, params) in SCENES.items():
        if parts and not any(part in name for part in parts):
            continue
        with tempfile.TemporaryDirectory() as tmp:
            os.environ["PULSEMAP_CACHE_DIR"] = tmp
            path = Path(tmp) / f"{name}.toml"
            path.write_text(scene_text(name, R, eps, params), encoding="utf-8")
            res = run_scene(load_scene(str(path)))
        with tempfile.TemporaryDirectory() as tmp:  # the relaxed model alone, cold, with its stated accuracy
            os.environ["PULSEMAP_CACHE_DIR"] = tmp
            path = Path(tmp) / f"{name}.toml"
            path.write_text(scene_text(name, R, eps, params), encoding="utf-8")
            t0 = time.perf_counter()
            alone = run_scene(load_scene(str(path)), methods=["relaxed"], reuse_dns=res)
            wall = time.perf_counter() - t0
        rel = res["errors"]["relaxed"]
        mp = res["errors"].get("map") or {"rms_pct": float("nan"), "max_pct": float("nan")}  # refused: a non-smooth R
        live = "{}..{}".format(*rel["live_range"])
        print(f"{name:24s} {live:>8s} {rel['rms_pct']:10.2f}% {rel['max_pct']:6.1f}% "
              f"{mp['rms_pct']:7.1f}% {mp['max_pct']:6.1f}% {res['timings_s']['relaxed']:7.2f} {wall:7.2f}"
              f" {alone['relaxed']['segment_runs']:5d}", flush=True)


if __name__ == "__main__":
    args = sys.argv[1:]
    main("--local" in args, "--first-order" in args, [a for a in args if not a.startswith("--")])
