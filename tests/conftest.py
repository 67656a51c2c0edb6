"""Shared test set-up: an isolated cache directory per test session; small scene files; a wheel installed into a
fresh venv."""

import io
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

# numba's compiled kernels are keyed by their source, so a test session may reuse the ones an earlier
# session compiled (the per-session cache below would otherwise compile them all again); a
# NUMBA_CACHE_DIR set outside wins. Set before any test module imports a kernel.
if not os.environ.get("NUMBA_CACHE_DIR"):
    from pulsemap.symbolic.cache import cache_root

    os.environ["NUMBA_CACHE_DIR"] = str(cache_root() / "numba")


# No progress line driven by the clock (a long DNS's, every few seconds): what a command prints must not
# depend on how fast this machine is (chain/dns_progress.py: PROGRESS_ENV); its own tests switch it back on.
os.environ["PULSEMAP_PROGRESS"] = "off"


@pytest.fixture(autouse=True, scope="session")
def _isolated_cache():
    """Every test session gets a fresh, empty on-disk cache (never the user's)."""
    old = os.environ.get("PULSEMAP_CACHE_DIR")
    with tempfile.TemporaryDirectory(prefix="pulsemap-test-cache-") as tmp:
        os.environ["PULSEMAP_CACHE_DIR"] = tmp
        yield tmp
    if old is None:
        os.environ.pop("PULSEMAP_CACHE_DIR", None)
    else:
        os.environ["PULSEMAP_CACHE_DIR"] = old


def scene_toml(name: str = "scene", *, beads: int | None = None, eps: float = 0.1, contacts: tuple[int, int] = (16, 30),
               methods: tuple[str, ...] = ("map", "longwave", "dns")) -> str:
    """The text of a small scene file: n = 1.5, beads 1..15 unperturbed, v0 = 1, R = -mu*v with mu = 1.

    One key a line; ``eps`` stands on line 10 with ``beads`` given, on line 9 without.
    """
    lines = [f'name = "{name}"', "[chain]"] + ([f"beads = {beads}"] if beads is not None else [])
    lines += ["exponent = 1.5", "first_perturbed = 16", "[excitation]", "velocity = 1.0", "[perturbation]",
              'R = "-mu*v"', f"eps = {eps}", "[perturbation.params]", "mu = 1.0", "[output]",
              f"contacts = [{contacts[0]}, {contacts[1]}]", f"methods = {json.dumps(list(methods))}"]
    return "\n".join(lines) + "\n"


def regenerated(path: Path, directory: Path) -> str:
    """The text the project's generator (codegen.write, as ``pulsemap generate``) writes into ``directory``
    for the source the generated file ``path`` names."""
    from pulsemap.symbolic import codegen
    from pulsemap.symbolic.sources import source_from_dict, verify_generated

    source = source_from_dict(verify_generated(Path(path).read_text(encoding="utf-8")))
    return codegen.write(source, directory).read_text(encoding="utf-8")


def write_scene(directory: Path, text: str, name: str = "scene.toml") -> Path:
    """Write a scene file's ``text`` as ``directory/name``; its path."""
    path = Path(directory) / name
    path.write_text(text, encoding="utf-8")
    return path


class Terminal(io.StringIO):
    """A stream that says it is a terminal; :meth:`screen` is what a terminal shows of what was written
    (the ANSI "cursor up, erase line" of chain/dns_progress.py removes the line above)."""

    def isatty(self) -> bool:
        return True

    def screen(self) -> list[str]:
        from pulsemap.solvers.chain.dns_progress import REPLACE_LAST

        lines: list[str] = []
        for part in self.getvalue().split(REPLACE_LAST):
            if lines:
                lines.pop()
            lines.extend(part.splitlines())
        return lines


ROOT = Path(__file__).resolve().parents[1]
WHEEL_SOURCES = ("derive", "generated", "solvers", "__init__.py", "py.typed", "pyproject.toml", "setup.py", "README.md",
                 "LICENSE")


def pip(*args: str) -> subprocess.CompletedProcess:
    """This interpreter's pip, quiet, raising on failure."""
    return subprocess.run([sys.executable, "-m", "pip", "--disable-pip-version-check", *args], capture_output=True,
                          text=True, timeout=600, check=True)


def installed_wheel(tmp_path: Path) -> tuple[Path, Path]:
    """The checkout's wheel, built from a copy (its build/ and egg-info stay out of the checkout), installed into a
    fresh venv made without pip or network: (the venv, its site-packages). Its dependencies are this interpreter's,
    through a .pth line that appends this interpreter's site-packages after the venv's own (the .pth files there,
    among them this checkout's editable install, are not processed), so ``import pulsemap`` finds the wheel."""
    import shutil
    import sysconfig

    src = tmp_path / "src"
    src.mkdir()
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "build", "*.egg-info")
    for name in WHEEL_SOURCES:
        if (ROOT / name).is_dir():
            shutil.copytree(ROOT / name, src / name, ignore=ignore)
        elif (ROOT / name).is_file():
            shutil.copy2(ROOT / name, src / name)
    pip("wheel", str(src), "--no-deps", "-w", str(tmp_path / "dist"))
    (wheel,) = (tmp_path / "dist").glob("pulsemap-*.whl")
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=300)
    python = venv / ("Scripts/python.exe" if os.name == "nt" else "bin/python")
    site = Path(subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                               capture_output=True, text=True, check=True).stdout.strip())
    (site / "_test_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n", encoding="utf-8")
    pip("--python", str(python), "install", "--no-index", "--no-deps", str(wheel))
    return venv, site
