"""Benchmark: building the relaxed map's tables from an empty cache, one fresh process per scene.

Run: python benchmarks/bench_relaxed_cold.py
Prints, measured in this run: per scene (fig6-eps0.3, fig7-eps0.3, fig8-eps0.3, a graded
foundation R = -(a + b (i - 16)) u, a = 1, b = -0.00865, eps = 0.1, and two non-smooth R: Coulomb
friction -mu sign(v), mu = 1.5, eps = 0.02, and -mu v |v|, mu = 1, eps = 0.3) the run's ``timings_s.relaxed``
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

SCENES = ["fig6-eps0.3", "fig7-eps0.3", "fig8-eps0.3", "graded", "coulomb", "v-abs-v"]


def scene_text(name: str, R: str, eps: float, params: list[str]) -> str:
    """A 140-bead scene file: n = 1.5, v0 = 1, beads 1..15 unperturbed, contacts 16..120."""
    return "\n".join([
        f'name = "{name}"', "[chain]", "beads = 140", "exponent = 1.5", "first_perturbed = 16", "[excitation]",
        "velocity = 1.0", "[perturbation]", f'R = "{R}"', f"eps = {eps}", "[perturbation.params]", *params,
        "[output]", "contacts = [16, 120]", 'methods = ["dns", "relaxed"]']) + "\n"


FILES = {"graded": scene_text("graded", "-(a + b*(i - 16))*u", 0.1, ['a = "1.0"', 'b = "-0.00865"']),
         "coulomb": scene_text("coulomb", "-mu*sign(v)", 0.02, ["mu = 1.5"]),
         "v-abs-v": scene_text("v-abs-v", "-mu*v*abs(v)", 0.3, ["mu = 1.0"])}


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
        for name, text in FILES.items():
            (tmp / f"{name}.toml").write_text(text, encoding="utf-8")
        scenes = [str(tmp / f"{s}.toml") if s in FILES else s for s in SCENES]
        for scene in scenes:  # warm-up: numba compiles the kernels into tmp/numba
            relaxed_build(exe, scene, tmp, "warm")
        print(f"{'scene':14s} {'relaxed cold s':>14s} {'runs':>5s}   (load average {os.getloadavg()[0]:.1f})")
        for label, scene in zip(SCENES, scenes):
            sec, runs = relaxed_build(exe, scene, tmp, label)
            print(f"{label:14s} {sec:14.2f} {runs:5d}")


if __name__ == "__main__":
    main()
