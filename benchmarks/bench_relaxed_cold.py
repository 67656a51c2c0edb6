"""Benchmark: building the relaxed map's tables from an empty cache, one fresh process per scene, against a baseline
commit's build side by side, with the ratio baseline / this checkout.

Run: python benchmarks/bench_relaxed_cold.py [--baseline COMMIT] [--rounds R] [--scenes fig8-eps0.3,graded]

Per scene (fig6-eps0.3, fig7-eps0.3, fig8-eps0.3, a graded foundation R = -(a + b (i - 16)) u, a = 1, b = -0.00865,
eps = 0.1, and two non-smooth R: Coulomb friction -mu sign(v), mu = 1.5, eps = 0.02, and -mu v |v|, mu = 1, eps = 0.3)
a fresh process runs ``pulsemap run SCENE --methods dns,relaxed`` with an empty PULSEMAP_CACHE_DIR (numba's kernels
compiled beforehand in a folder of their own, by a warm-up pass of each side) and reports the CPU time of its
relaxed model (model_for_scene, the iteration and the stated accuracy: what ``timings_s.relaxed`` times, in CPU
seconds of all the process's threads). The baseline runs from ``git archive`` of the baseline commit (imported from
a temporary folder), this checkout from its own sources, in interleaved rounds (baseline, new, baseline, new, ...;
the best of R rounds each, so a load spike costs both sides alike). Each line also says whether the relaxed peaks
of the two sides are the same bit for bit. Target: fig8-eps0.3 and graded >= 2x the baseline.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import baseline

#: The build before a segment run stopped executing R's generated force module anew (docs/benchmarks.rst, "The
#: relaxed transfer map").
BASELINE = "f3ad30f"
REPO = baseline.REPO
SCENES = ["fig6-eps0.3", "fig7-eps0.3", "fig8-eps0.3", "graded", "coulomb", "v-abs-v"]
#: The child: runs one scene with the relaxed model's runner timed in CPU seconds, prints what it measured
#: (argv: the source folder or "", the scene, the json path).
CHILD = """\
import dataclasses, hashlib, json, sys, time
import pulsemap
assert pulsemap.__file__.startswith(sys.argv[1]), pulsemap.__file__
from pulsemap.solvers.cli import main as cli
getattr(cli, "one_blas_thread", lambda: None)()  # as each side's console script does, before numpy loads
from pulsemap.solvers.studies.run import models
spent = {}
runner = models.RUNNERS["relaxed"]
def timed(state, name, inputs, run=runner.run):
    t0 = time.process_time()
    try:
        return run(state, name, inputs)
    finally:
        spent["cpu"] = time.process_time() - t0
models.RUNNERS["relaxed"] = dataclasses.replace(runner, run=timed)
try:
    cli.main(["run", sys.argv[2], "--methods", "dns,relaxed", "--quiet", "--json", sys.argv[3]])
except SystemExit as exc:
    assert not exc.code, exc.code
out = json.loads(open(sys.argv[3], encoding="utf-8").read())
peaks = hashlib.sha256(json.dumps(out["peaks"]["relaxed"]).encode()).hexdigest()
print(json.dumps({"cpu": spent["cpu"], "runs": out["relaxed"]["segment_runs"], "peaks": peaks}))
"""


def scene_text(name: str, R: str, eps: float, params: list[str]) -> str:
    """A 140-bead scene file: n = 1.5, v0 = 1, beads 1..15 unperturbed, contacts 16..120."""
    return "\n".join([
        f'name = "{name}"', "[chain]", "beads = 140", "exponent = 1.5", "first_perturbed = 16", "[excitation]",
        "velocity = 1.0", "[perturbation]", f'R = "{R}"', f"eps = {eps}", "[perturbation.params]", *params,
        "[output]", "contacts = [16, 120]", 'methods = ["dns", "relaxed"]']) + "\n"


FILES = {"graded": scene_text("graded", "-(a + b*(i - 16))*u", 0.1, ['a = "1.0"', 'b = "-0.00865"']),
         "coulomb": scene_text("coulomb", "-mu*sign(v)", 0.02, ["mu = 1.5"]),
         "v-abs-v": scene_text("v-abs-v", "-mu*v*abs(v)", 0.3, ["mu = 1.0"])}


def relaxed_build(src: Path | None, scene: str, tmp: Path, tag: str) -> dict:
    """{cpu, runs, peaks} of one fresh process with an empty pulsemap cache (``src``: the baseline's sources)."""
    env = {**os.environ, "PULSEMAP_CACHE_DIR": str(tmp / f"cache-{tag}"), "NUMBA_CACHE_DIR": str(tmp / "numba")}
    if src is not None:
        env["PYTHONPATH"] = str(src.parent)
    run = subprocess.run([sys.executable, "-c", CHILD, str(src or REPO), scene, str(tmp / f"{tag}.json")], env=env,
                         cwd=str(tmp), capture_output=True, text=True)
    if run.returncode != 0:
        said = run.stderr.strip().splitlines()[-1:] or ["no output"]
        sys.exit(f"bench_relaxed_cold: {scene} on {'the baseline' if src else 'this checkout'} failed ({said[0]})")
    return json.loads(run.stdout.strip().splitlines()[-1])


def main(argv: list[str]) -> None:
    opts, labels = baseline.options(argv, __doc__, BASELINE, 3, "scenes", SCENES)
    print(f"bench_relaxed_cold: this checkout against {opts.baseline}, relaxed model's CPU s from an empty cache, best "
          f"of {opts.rounds} interleaved rounds; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores",
          flush=True)
    with tempfile.TemporaryDirectory(prefix="bench-relaxed-cold-") as name:
        tmp = Path(name)
        for label, text in FILES.items():
            (tmp / f"{label}.toml").write_text(text, encoding="utf-8")
        scenes = {s: str(tmp / f"{s}.toml") if s in FILES else s for s in labels}
        sides = {"baseline": baseline.sources(opts.baseline, tmp / "baseline", "bench_relaxed_cold"), "new": None}
        for side, src in sides.items():  # warm-up: numba builds the kernels into tmp/numba
            for label, scene in scenes.items():
                relaxed_build(src, scene, tmp, f"warm-{side}-{label}")
        print(f"  {'scene':14s} {'runs':>5s} {'baseline s':>10s} {'new s':>7s} {'ratio':>6s}  peaks", flush=True)
        for label, scene in scenes.items():
            seen: dict[str, list[dict]] = {side: [] for side in sides}
            for r in range(opts.rounds):
                for side, src in sides.items():
                    seen[side].append(relaxed_build(src, scene, tmp, f"{side}-{label}-{r}"))
            best = {side: min(m["cpu"] for m in seen[side]) for side in sides}
            same = len({m["peaks"] for side in sides for m in seen[side]}) == 1
            runs = sorted({m["runs"] for side in sides for m in seen[side]})
            print(f"  {label:14s} {'/'.join(map(str, runs)):>5s} {best['baseline']:10.3f} {best['new']:7.3f} "
                  f"{best['baseline'] / best['new']:5.2f}x  {'same bit for bit' if same else 'DIFFER'}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
