"""The import structure the design promises: imports run one way (cli -> api -> studies ->
models/data -> chain -> derive), derive/ never imports scipy, numba or solvers/, and solvers/ never
imports sympy at import time (only inside the functions that need it, e.g. to generate missing code)."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FLOOR = {"cli": 6, "api": 5, "studies": 4, "models": 3, "data": 3, "chain": 2, "derive": 1, "generated": 0}
#: solvers/ modules that are symbolic by purpose; each is imported only inside the functions that use it.
SYMBOLIC = {"solvers/studies/dressed.py"}


def _district(path: Path) -> str:
    rel = path.relative_to(ROOT).parts
    return rel[1] if rel[0] == "solvers" and len(rel) > 2 else rel[0]


def _imports(tree: ast.AST):
    """(module name, at module level?) of every import in the file."""
    top = {id(node) for node in tree.body}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, id(node) in top
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            yield node.module, id(node) in top


def _target(module: str) -> str | None:
    parts = module.split(".")
    if parts[0] != "pulsemap" or len(parts) < 2:
        return None
    if parts[1] == "solvers":
        return parts[2] if len(parts) > 2 else None
    return "derive" if parts[1] == "symbolic" else parts[1]  # the derive/ folder installs as pulsemap.symbolic


SOURCES = sorted(p for folder in ("derive", "solvers") for p in (ROOT / folder).rglob("*.py"))


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(ROOT)))
def test_imports_run_one_way(path):
    here = _district(path)
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for module, top_level in _imports(tree):
        there = _target(module)
        if there in FLOOR and here in FLOOR and there != here:
            assert FLOOR[there] < FLOOR[here], f"{path.relative_to(ROOT)} imports {module}: an arrow back up"
        if here == "derive":
            assert module.split(".")[0] not in ("scipy", "numba"), f"derive imports {module}"
            assert there not in ("cli", "api", "studies", "chain", "models", "data"), f"derive imports {module}"
        elif top_level and str(path.relative_to(ROOT)) not in SYMBOLIC:
            assert module.split(".")[0] != "sympy", f"{path.relative_to(ROOT)} imports sympy at module level"



def _private_imports(tree: ast.AST):
    """Every ``from pulsemap... import _name`` (a private name taken across a module boundary)."""
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == "pulsemap":
            for alias in node.names:
                if alias.name.startswith("_") and not alias.name.startswith("__"):
                    yield f"from {node.module} import {alias.name}"


def test_private_import_check_finds_one():
    tree = ast.parse("from pulsemap.solvers.chain.dns import _real, simulate\nfrom pulsemap import __version__")
    assert list(_private_imports(tree)) == ["from pulsemap.solvers.chain.dns import _real"]


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_private_name_crosses_a_module(path):
    """A name shared between modules is public (no underscore, a docstring), or the modules are one."""
    found = list(_private_imports(ast.parse(path.read_text(encoding="utf-8"))))
    assert not found, f"{path.relative_to(ROOT)}: {found}"

@pytest.mark.process
def test_the_command_and_a_run_load_no_sympy():
    code = ("import sys, pulsemap.solvers.cli.main, pulsemap.solvers.studies.run, pulsemap.solvers.studies.table; "
            "print('sympy' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


@pytest.mark.process
def test_the_compiled_dns_and_a_run_load_no_scipy_solvers():
    """scipy's integrators and root finders (~0.3 s per process) load only where a scipy engine, a law
    or a root search runs: importing the DNS front end and `run` leaves them out."""
    code = ("import sys, pulsemap.solvers.chain.dns, pulsemap.solvers.studies.run; "
            "print(sorted(m for m in ('scipy.integrate', 'scipy.optimize', 'scipy.sparse') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
