"""A wheel installed into a fresh venv runs the DNS without writing into its own package, with the chain kernels
its build compiled (setup.py), and uninstalls without leaving anything behind; numba's kernels and the code
generated at run time land in the pulsemap cache.

The venv is created with ``python -m venv`` (no pip, no network) and the wheel installed into it
with ``pip --python VENV install --no-index --no-deps``. Its dependencies (numpy, scipy, numba,
sympy) are the ones of the interpreter running the tests, made visible through a .pth file that
lists that interpreter's site-packages: a .pth line only appends a folder to sys.path (the .pth
files inside it, among them this checkout's editable install, are not processed), and the venv's
own site-packages comes first, so ``import pulsemap`` finds the installed wheel (asserted).
"""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest

from conftest import installed_wheel, pip
from pulsemap.solvers.chain import compiled_aot


def _files(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


@pytest.mark.process
def test_wheel_runs_read_only_and_uninstalls_clean(tmp_path):
    venv, site = installed_wheel(tmp_path)
    python = venv / ("Scripts/python.exe" if os.name == "nt" else "bin/python")
    package = site / "pulsemap"
    installed = _files(package)

    cache = tmp_path / "cache"
    env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "PULSEMAP_", "PYTHON"))}
    env["PULSEMAP_CACHE_DIR"] = str(cache)
    where = subprocess.run([str(python), "-c", "import pulsemap; print(pulsemap.__file__)"], env=env,
                           capture_output=True, text=True, check=True).stdout.strip()
    assert Path(where).parent == package, where
    command = [str(venv / "bin" / "pulsemap"), "run", "default", "--methods", "dns", "--json"]
    first = subprocess.run(command + [str(tmp_path / "first.json")], env=env, capture_output=True, text=True,
                           timeout=900)
    assert first.returncode == 0, first.stderr[-2000:]
    built = {p.name.split(".")[0] for p in (package / "solvers" / "chain" / "aot").iterdir()}
    assert built == {compiled_aot.module_name(m, f) for m, f in compiled_aot.INSTALL_KERNELS}, \
        "the wheel's build environment got another numba or numpy than this one (pip's isolated build)"
    assert not (cache / "numba" / "aot").exists() or not list((cache / "numba" / "aot").glob("pulsemap_*"))
    assert "compiling the chain kernels" not in first.stderr, first.stderr  # the wheel's own, built at install
    again = subprocess.run(command + [str(tmp_path / "again.json")], env=env, capture_output=True, text=True,
                           timeout=300)
    assert again.returncode == 0, again.stderr[-2000:]
    assert "compiling" not in again.stderr, again.stderr  # warm: loaded from the cache, silently
    peaks = [json.loads((tmp_path / f"{n}.json").read_text())["peaks"]["dns"] for n in ("first", "again")]
    assert peaks[0] == peaks[1] and any(p is not None for p in peaks[0])

    # an R the package ships no code for: its force and numba force modules are generated at run time
    generated = subprocess.run(command[:-1] + ["--set", "perturbation.R=-mu*sin(u)"], env=env, capture_output=True,
                               text=True, timeout=900)
    assert generated.returncode == 0, generated.stderr[-2000:]
    made = sorted(p.name for p in (cache / "generated").glob("*.py"))
    assert any(n.startswith("jitforce_") for n in made) and any(n.startswith("force_") for n in made), made

    assert _files(package) == installed, sorted(_files(package) - installed)  # nothing written inside it
    numba_files = [p.name for p in (cache / "numba").rglob("*") if p.suffix in (".nbi", ".nbc")]
    assert any(n.endswith(".nbc") for n in numba_files) and any(n.endswith(".nbi") for n in numba_files)

    pip("--python", str(python), "uninstall", "-y", "pulsemap")
    left = sorted(p.name for p in site.iterdir() if p.name.lower().startswith("pulsemap"))
    assert left == [] and not package.exists(), left
