"""pulsemap's one build step beyond pyproject.toml: a non-editable install (``pip install .``) builds the chain
kernels most runs take into the package (solvers/chain/compiled_aot.py, INSTALL_KERNELS), so that no first run
waits for their build. Where that fails (no C compiler) the install goes on and the first run builds them."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py


def build_kernels(lib: Path) -> None:
    """Build compiled_aot.INSTALL_KERNELS from the package in ``lib`` (a build folder) into its
    pulsemap/solvers/chain/aot folder, with empty caches of their own; a failure leaves no folder."""
    with tempfile.TemporaryDirectory(prefix="pulsemap-kernels-") as tmp:
        env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "PULSEMAP_"))}
        # the package from the build folder, numba from the build environment (pip's, on PYTHONPATH)
        env.update(PYTHONPATH=os.pathsep.join([str(lib), *filter(None, [os.environ.get("PYTHONPATH")])]),
                   NUMBA_CACHE_DIR=str(Path(tmp) / "numba"), PULSEMAP_CACHE_DIR=str(Path(tmp) / "pulsemap"))
        done = subprocess.run([sys.executable, "-m", "pulsemap.solvers.chain.compiled_aot"], env=env, cwd=tmp,
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        built = [p for p in (Path(tmp) / "numba" / "aot").glob("pulsemap_*") if not p.name.endswith(".failed")]
        if done.returncode != 0 or not built:
            said = (done.stderr.strip().splitlines() or ["no output"])[-1]
            print(f"pulsemap: the chain kernels were not built at install ({said}); the first run builds them",
                  file=sys.stderr)
            return
        dest = lib / "pulsemap" / "solvers" / "chain" / "aot"
        dest.mkdir(exist_ok=True)
        for path in built:
            shutil.copyfile(path, dest / path.name)


class BuildWithKernels(build_py):
    """build_py, then the chain kernels (build_kernels) unless the install is editable."""

    def run(self) -> None:
        super().run()
        if not getattr(self, "editable_mode", False) and not self.dry_run:
            build_kernels(Path(self.build_lib).resolve())


if __name__ == "__main__":  # as setuptools' build backend runs it (tests import build_kernels)
    setup(cmdclass={"build_py": BuildWithKernels})
