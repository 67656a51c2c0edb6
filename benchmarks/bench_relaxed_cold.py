"""Benchmark: building the relaxed map's tables from an empty cache, one fresh process per scene.

Run: python benchmarks/bench_relaxed_cold.py
Prints, measured in this run: per scene (fig6-eps0.3, fig7-eps0.3, fig8-eps0.3 and a graded
foundation R = -(a + b (i - 16)) u, a = 1, b = -0.00865, eps = 0.1) the run's ``timings_s.relaxed``
of ``pulsemap run SCENE --methods dns,relaxed`` with an empty PULSEMAP_CACHE_DIR (numba's kernels
compiled beforehand in a folder of their own, by a warm-up pass), and its segment runs.
Target: <= 2 s per scene on the 2-core machine.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

SCENES = ["fig6-eps0.3", "fig7-eps0.3", "fig8-eps0.3", "graded"]
GRADED = "\n".join([
    'name = "graded"', "[chain]", "beads = 140", "exponent = 1.5", "first_perturbed = 16", "[excitation]",
    "velocity = 1.0", "[perturbation]", 'R = "-(a + b*(i - 16))*u"', "eps = 0.1", "[perturbation.params]",
    'a = "1.0"', 'b = "-0.00865"', "[output]", "contacts = [16, 120]", 'methods = ["dns", "relaxed"]']) + "\n"


def relaxed_build(exe: str, scene: str, tmp: Path, tag: str) -> tuple[float, int]:
    """(timings_s.relaxed, segment runs) of one fresh process with an empty pulsemap cache."""
    out = tmp / f"{tag}.json"
    env = {**os.environ, "PULSEMAP_CACHE_DIR": str(tmp / f"cache-{tag}"), "NUMBA_CACHE_DIR": str(tmp / "numba")}
    subprocess.run([exe, "run", scene, "--methods", "dns,relaxed", "--quiet", "--json", str(out)], env=env,
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    data = json.loads(out.read_text(encoding="utf-8"))
    return float(data["timings_s"]["relaxed"]), int(data["relaxed"]["segment_runs"])


def main() -> None:
    exe = str(Path(sys.executable).with_name("pulsemap"))
    with tempfile.TemporaryDirectory(prefix="bench-relaxed-cold-") as name:
        tmp = Path(name)
        (tmp / "graded.toml").write_text(GRADED, encoding="utf-8")
        scenes = [str(tmp / "graded.toml") if s == "graded" else s for s in SCENES]
        for scene in scenes:  # warm-up: numba compiles the kernels into tmp/numba
            relaxed_build(exe, scene, tmp, "warm")
        print(f"{'scene':14s} {'relaxed cold s':>14s} {'runs':>5s}   (load average {os.getloadavg()[0]:.1f})")
        for label, scene in zip(SCENES, scenes):
            sec, runs = relaxed_build(exe, scene, tmp, label)
            print(f"{label:14s} {sec:14.2f} {runs:5d}")


if __name__ == "__main__":
    main()
