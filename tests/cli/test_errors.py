"""One error base: every error pulsemap raises for what it was asked is a PulsemapError, only those (and
OSError) are "pulsemap: error: ..., exit 2", and anything else is a bug that says so; one closest()
for every "did you mean"."""

from __future__ import annotations

import importlib
import pkgutil
import re
from pathlib import Path

import pytest

import pulsemap
from pulsemap.solvers.cli import main as cli_main
from pulsemap.symbolic.errors import PulsemapError, closest

ROOT = Path(__file__).resolve().parents[2]

# Exceptions that are no user error: internal signals caught below the faces, or an inconsistency in
# pulsemap itself (a bug).
INTERNAL = {"CodegenError", "IntegratorFailed", "_Problem"}


def _project_modules():
    for package in ("pulsemap.symbolic", "pulsemap.solvers"):
        root = importlib.import_module(package)
        yield root
        for info in pkgutil.walk_packages(root.__path__, package + "."):
            yield importlib.import_module(info.name)


def test_every_project_error_is_a_pulsemap_error():
    seen = {}
    for module in _project_modules():
        for name, obj in vars(module).items():
            if isinstance(obj, type) and issubclass(obj, Exception) and obj.__module__ == module.__name__:
                seen[f"{module.__name__}.{name}"] = obj
    assert len(seen) > 30  # the walk found the project's classes
    strays = [name for name, cls in seen.items()
              if not issubclass(cls, (PulsemapError, OSError)) and cls.__name__ not in INTERNAL]
    assert not strays, f"error classes outside PulsemapError: {strays}"
    assert pulsemap.PulsemapError is PulsemapError and issubclass(PulsemapError, ValueError)


def _command_raising(monkeypatch, exc: BaseException):
    """`pulsemap profile` with its command function replaced by one that raises ``exc``."""
    parser = cli_main.build_parser
    def build():
        p = parser()
        sub = next(a for a in p._actions if a.dest == "command")
        def boom(args):
            raise exc
        sub.choices["profile"].set_defaults(func=boom)
        return p
    monkeypatch.setattr(cli_main, "build_parser", build)


@pytest.mark.parametrize("bug", [ValueError("math domain error"), KeyError("amplitude"), ZeroDivisionError("x"),
                                 RuntimeError("stale state")], ids=lambda e: type(e).__name__)
def test_an_injected_bug_is_an_internal_error_not_bad_input(monkeypatch, capsys, bug):
    monkeypatch.delenv(cli_main.TRACEBACK_ENV, raising=False)
    _command_raising(monkeypatch, bug)
    code = cli_main.main(["profile"])
    err = capsys.readouterr().err
    assert code == cli_main.EXIT_BUG != cli_main.EXIT_USAGE
    assert err.count("\n") == 1 and "pulsemap: error" not in err
    assert err.startswith("pulsemap: internal error, please report: " + type(bug).__name__)
    assert "test_errors.py" in err and cli_main.TRACEBACK_ENV in err and "Traceback" not in err


def test_the_traceback_of_a_bug_is_behind_the_environment_variable(monkeypatch, capsys):
    monkeypatch.setenv(cli_main.TRACEBACK_ENV, "1")
    _command_raising(monkeypatch, KeyError("amplitude"))
    assert cli_main.main(["profile"]) == cli_main.EXIT_BUG
    err = capsys.readouterr().err
    assert "Traceback (most recent call last)" in err and "in boom" in err
    assert err.rstrip().splitlines()[-1].startswith("pulsemap: internal error, please report: KeyError")


def test_a_pulsemap_error_is_bad_input(monkeypatch, capsys):
    from pulsemap.solvers.data.scene import SceneError

    _command_raising(monkeypatch, SceneError("scene 'x': beads must be >= 2\nsecond line"))
    assert cli_main.main(["profile"]) == cli_main.EXIT_USAGE
    assert capsys.readouterr().err == "pulsemap: error: scene 'x': beads must be >= 2\n"


def test_closest():
    assert closest("velocty", ["velocity", "exponent"]) == "velocity"
    assert closest("DNS", ["dns", "map"]) == "dns"  # case alone differs: that name, whatever difflib says
    assert closest("zzz", ["velocity", "exponent"]) is None
    assert closest("mu0x", ["mu0"], cutoff=0.9) is None and closest("mu0x", ["mu0"]) == "mu0"
    assert closest("x", []) is None


def test_every_did_you_mean_uses_closest():
    users = [p.relative_to(ROOT) for folder in ("derive", "solvers") for p in (ROOT / folder).rglob("*.py")
             if re.search(r"\bdifflib\b", p.read_text(encoding="utf-8"))]
    assert users == [Path("derive/errors.py")]


def test_a_bad_environment_setting_is_bad_input_not_a_bug(monkeypatch, capsys):
    monkeypatch.setenv("PULSEMAP_PROGRESS", "bogus")
    assert cli_main.main(["run", "default", "--methods", "dns"]) == cli_main.EXIT_USAGE
    err = capsys.readouterr().err.splitlines()
    assert err[-1] == "pulsemap: error: PULSEMAP_PROGRESS='bogus': give auto, lines or off"
