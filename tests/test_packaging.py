"""Every data file the package reads is installed by a normal (non-editable) install: it matches a
[tool.setuptools.package-data] pattern of pyproject.toml (a shipped calibration missing from the
wheel made `pip install .` recompute it on first use)."""

from __future__ import annotations

import fnmatch
import sys
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
SOURCES = ("derive", "generated", "solvers")


def _patterns() -> dict[Path, list[str]]:
    data = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    table = data["tool"]["setuptools"].get("package-data", {})
    # "pulsemap.solvers.data" -> solvers/data (package-dir maps pulsemap to the repository root)
    return {ROOT.joinpath(*pkg.split(".")[1:]): pats for pkg, pats in table.items()}


def test_every_data_file_is_package_data():
    patterns = _patterns()
    missing = []
    for top in SOURCES:
        for path in (ROOT / top).rglob("*"):
            if not path.is_file() or path.suffix in (".py", ".pyc", ".nbi", ".nbc") or "__pycache__" in path.parts:
                continue
            covered = any(path.is_relative_to(pkg) and any(fnmatch.fnmatch(path.relative_to(pkg).as_posix(), p)
                                                           for p in pats)
                          for pkg, pats in patterns.items())
            if not covered:
                missing.append(path.relative_to(ROOT).as_posix())
    assert not missing, f"not installed by `pip install .` (add to [tool.setuptools.package-data]): {missing}"


def _folder(package: str, package_dir: dict[str, str]) -> Path:
    """The source folder of an installed package name under [tool.setuptools] package-dir."""
    prefix = max((p for p in package_dir if package == p or package.startswith(p + ".")), key=len)
    return ROOT.joinpath(package_dir[prefix], *package[len(prefix):].split(".")[1:]).resolve()


def test_every_source_package_is_installed():
    """A sub-package missing from [tool.setuptools] packages is missing from the wheel."""
    setup = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"]
    listed = {_folder(name, setup["package-dir"]) for name in setup["packages"]}
    found = {p.parent.resolve() for top in SOURCES for p in (ROOT / top).rglob("__init__.py")}
    missing = sorted(p.relative_to(ROOT).as_posix() for p in found - listed)
    assert not missing, f"not installed by `pip install .` (add to [tool.setuptools] packages): {missing}"
    assert all((folder / "__init__.py").is_file() for folder in listed), "a listed package has no __init__.py"


def test_the_readme_installs_extras_of_the_checkout_editable():
    """A developer's command with an extra (tests, docs) keeps the checkout's install editable: a plain
    ``pip install '.[docs]'`` would replace it with a copy that edits no longer reach."""
    import re

    text = (ROOT / "README.md").read_text(encoding="utf-8")
    commands = re.findall(r"pip install[^`\n]*'\.\[\w+\]'", text)
    assert {"test", "docs"} <= {re.search(r"\[(\w+)\]", c).group(1) for c in commands}
    assert all(" -e " in c for c in commands), commands
