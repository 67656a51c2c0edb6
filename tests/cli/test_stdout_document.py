"""``--json -`` and ``--csv -``: stdout holds the document and nothing else.

Every command with a --json option is run with ``--json -`` on a small input; stdout must parse
with json.loads (strict: no NaN), and the text report must have gone to stderr. ``--csv -`` must
write CSV to stdout (not a file named '-').
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from conftest import scene_toml, write_scene
from pulsemap.solvers.cli.main import main


@pytest.fixture()
def tiny(tmp_path) -> str:
    return str(write_scene(tmp_path, scene_toml("tiny", beads=40, contacts=(16, 30)), "tiny.toml"))


def _strict(text: str):
    def refuse(token):
        raise AssertionError(f"non-standard JSON number {token}")

    return json.loads(text, parse_constant=refuse)


# (command, argv after the command (TINY stands for the small scene file), a word of the text report)
COMMANDS = [
    ("profile", [], "S(0)"),
    ("derive", ["-mu*v", "--param", "mu=1", "--sympy-seconds", "0"], "R(u, v)"),
    ("run", ["TINY", "--quiet"], "scene tiny"),
    ("table", ["TINY", "--rows", "ROWS", "--quiet"], "Scenes won"),
    pytest.param("bench", ["TINY", "--quick", "--no-baselines", "--no-models", "--no-cold", "--repeats", "1"], "tiny",
                 marks=pytest.mark.bench),
    ("suite", ["TINY", "--no-check"], "tiny"),
    ("bifurcation", ["vdp-mu3-v2.3", "--param", "mu", "--range", "2", "4", "--no-dns", "--predict-points", "5",
                     "--workers", "1", "--quiet"], "fold"),
    ("sweep", ["TINY", "--over", "perturbation.eps=0.05,0.1", "--methods", "dns", "--workers", "1", "--quiet"],
     "points run"),
    ("ensemble", ["fig13-seed1", "--realisations", "1", "--contacts", "16", "20", "--workers", "1", "--quiet"],
     "realisation"),
]


@pytest.mark.parametrize("command, argv, word", COMMANDS, ids=[c.values[0] if hasattr(c, "values") else c[0] for c in COMMANDS])
def test_json_dash_is_the_only_thing_on_stdout(command, argv, word, tiny, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    argv = [tiny if a == "TINY" else str(tmp_path / "rows.jsonl") if a == "ROWS" else a for a in argv]
    code = main([command, *argv, "--json", "-"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    document = _strict(captured.out)
    assert isinstance(document, dict) and document
    assert word in captured.err  # the text report went to stderr
    assert not (tmp_path / "-").exists()


@pytest.mark.parametrize("command, argv, head", [
    ("run", ["TINY", "--quiet"], "contact,dns,map,longwave"),
    pytest.param("bench", ["TINY", "--quick", "--no-baselines", "--no-models", "--no-cold", "--repeats", "1"],
                 "scene,kind,line", marks=pytest.mark.bench),
], ids=["run", "bench"])
def test_csv_dash_writes_csv_to_stdout(command, argv, head, tiny, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code = main([command, *[tiny if a == "TINY" else a for a in argv], "--csv", "-"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    lines = captured.out.splitlines()
    assert lines[0].startswith(head) and len(lines) > 2
    assert all(line.count(",") == lines[0].count(",") for line in lines)
    assert not (tmp_path / "-").exists()


def test_json_and_csv_both_on_stdout_is_a_usage_error(tiny, capsys):
    assert main(["run", tiny, "--json", "-", "--csv", "-"]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and "both ask for stdout" in captured.err and captured.err.count("\n") == 1


@pytest.mark.process
def test_a_real_process_keeps_stdout_clean(tiny, tmp_path):
    """File-descriptor level: also what C code or workers would print goes to stderr."""
    out = subprocess.run([sys.executable, "-m", "pulsemap.solvers.cli.main", "run", tiny, "--json", "-"],
                         capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert out.returncode == 0, out.stderr
    assert _strict(out.stdout)["contacts"][0] == 16
    assert "scene tiny" in out.stderr


def test_non_finite_numbers_are_written_as_null(tmp_path):
    from pulsemap.solvers.cli.common import write_json

    path = tmp_path / "x.json"
    write_json(str(path), {"a": float("nan"), "b": [1.0, float("inf")], "c": {"d": -float("inf")}})
    assert _strict(path.read_text()) == {"a": None, "b": [1.0, None], "c": {"d": None}}
