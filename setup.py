"""pulsemap's one build step beyond pyproject.toml: a non-editable install (``pip install .``) builds the chain
kernels most runs take into the package (solvers/chain/compiled_aot.py, INSTALL_KERNELS), so that no first run
waits for their build. Where that fails (no C compiler; ``pip install -v`` shows why) the install goes on and a
run takes what it would have taken without (docs/dns.rst, "The first run")."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py
from setuptools.dist import Distribution

#: Seconds the kernels' build may take before the install goes on without them (a hung compiler).
BUILD_TIMEOUT_S = 1800


def build_kernels(lib: Path) -> None:
    """Build compiled_aot.INSTALL_KERNELS from the package in ``lib`` (a build folder) into its
    pulsemap/solvers/chain/aot folder, with empty caches of their own; a failure leaves no folder."""
    dest = lib / "pulsemap" / "solvers" / "chain" / "aot"
    shutil.rmtree(dest, ignore_errors=True)  # an earlier build's modules (pip builds in the source tree's build/)
    with tempfile.TemporaryDirectory(prefix="pulsemap-kernels-") as tmp:
        env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "PULSEMAP_"))}
        # the package from the build folder, numba from the build environment (pip's, on PYTHONPATH)
        env.update(PYTHONPATH=os.pathsep.join([str(lib), *filter(None, [os.environ.get("PYTHONPATH")])]),
                   NUMBA_CACHE_DIR=str(Path(tmp) / "numba"), PULSEMAP_CACHE_DIR=str(Path(tmp) / "pulsemap"))
        try:
            done = subprocess.run([sys.executable, "-m", "pulsemap.solvers.chain.compiled_aot"], env=env, cwd=tmp,
                                  stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                                  timeout=BUILD_TIMEOUT_S)
            said = (done.stderr.strip().splitlines() or ["no output"])[-1] if done.returncode else ""
        except subprocess.TimeoutExpired:
            said = f"not done in {BUILD_TIMEOUT_S} s"
        built = [p for p in (Path(tmp) / "numba" / "aot").glob("pulsemap_*") if not p.name.endswith(".failed")]
        if said or not built:
            print(f"pulsemap: the chain kernels were not built at install ({said or 'none built'}); a run builds "
                  "them when it needs them", file=sys.stderr)
            return
        dest.mkdir()
        for path in built:
            shutil.copyfile(path, dest / path.name)


class BuildWithKernels(build_py):
    """build_py, then the chain kernels (build_kernels) unless the install is editable."""

    def run(self) -> None:
        super().run()
        if not getattr(self, "editable_mode", False) and not self.dry_run:
            build_kernels(Path(self.build_lib).resolve())


class WithKernels(Distribution):
    """A distribution that holds this platform's compiled kernels: its wheel is tagged for the platform."""

    def has_ext_modules(self) -> bool:
        return True


if __name__ == "__main__":  # as setuptools' build backend runs it (tests import build_kernels)
    setup(cmdclass={"build_py": BuildWithKernels}, distclass=WithKernels)
