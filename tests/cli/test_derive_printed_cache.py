"""A warm ``pulsemap derive`` reads the printed derivation back from the cache (derive/printed.py).

What must hold: the same output as the derivation that stored it (stdout byte for byte, JSON apart
from ``timings_s``); no sympy imported on that path; a change of any option, of the code or of a
library version derives again; a damaged entry is derived again, never served.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from pulsemap.solvers.cli.main import main
from pulsemap.symbolic import derivation, printed

ROOT = Path(__file__).resolve().parents[2]
VDP = ["derive", "-(u - mu*(1-u^2)*v)", "--param", "mu=3", "--fold", "mu", "--sympy-seconds", "0"]

# one fresh process: the command's stdout, then (on stderr) whether sympy was imported
PROBE = ("import sys; from pulsemap.solvers.cli.main import main; rc = main(sys.argv[1:]); "
         "print('sympy' in sys.modules, rc, file=sys.stderr)")


@pytest.fixture()
def own_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("PULSEMAP_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


@pytest.fixture()
def derivations(monkeypatch):
    """The calls of derive_model made by the CLI (each a real derivation)."""
    calls = []
    real = derivation.derive_model

    def counting(*args, **kw):
        calls.append(args[0].text)
        return real(*args, **kw)

    monkeypatch.setattr(derivation, "derive_model", counting)
    return calls


def _fresh(argv: list[str], cache: Path) -> tuple[str, str]:
    env = {**os.environ, "PULSEMAP_CACHE_DIR": str(cache),
           "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.run([sys.executable, "-c", PROBE, *argv], capture_output=True, text=True, env=env, timeout=300)
    return proc.stdout, proc.stderr.splitlines()[-1]


def test_a_warm_derive_in_a_fresh_process_prints_the_same_without_sympy(tmp_path):
    cold_out, cold_probe = _fresh(VDP + ["--json", str(tmp_path / "cold.json")], tmp_path / "cache")
    warm_out, warm_probe = _fresh(VDP + ["--json", str(tmp_path / "warm.json")], tmp_path / "cache")
    assert (cold_probe, warm_probe) == ("True 0", "False 0")
    assert warm_out == cold_out and "saddle-node in mu" in cold_out
    cold, warm = (json.loads((tmp_path / f"{t}.json").read_text()) for t in ("cold", "warm"))
    assert set(cold["timings_s"]) >= {"expansion", "integrals", "total"} and set(warm["timings_s"]) == {"cache", "total"}
    assert {**warm, "timings_s": None} == {**cold, "timings_s": None}
    assert warm["stationary"]["fold"]["param"] == "mu"


def test_latex_and_text_are_stored_apart(own_cache, derivations, capsys):
    outs = []
    for argv in (VDP, VDP + ["--latex"], VDP, VDP + ["--latex"]):
        assert main(argv) == 0
        outs.append(capsys.readouterr().out)
    assert len(derivations) == 2  # one derivation per printed form, then both read back
    assert outs[0] == outs[2] and outs[1] == outs[3] and outs[1].startswith("% pulsemap derivation")


def test_another_option_the_code_or_a_library_version_derives_again(own_cache, derivations, monkeypatch, capsys):
    assert main(VDP) == 0 and main(VDP) == 0
    first = capsys.readouterr().out
    assert len(derivations) == 1 and first.count("Model: map") == 2
    assert main(VDP[:3] + ["mu=2"] + VDP[4:]) == 0
    assert len(derivations) == 2 and capsys.readouterr().out != first[: len(first) // 2]
    monkeypatch.setattr(printed, "code_digest", lambda: "0" * 64)  # an edited source file
    assert main(VDP) == 0 and len(derivations) == 3
    monkeypatch.setattr(printed, "provenance", lambda: {"sympy": "0.0"})  # another library version
    assert main(VDP) == 0 and len(derivations) == 4
    assert capsys.readouterr().out == first[: len(first) // 2] * 2


def test_a_damaged_printed_entry_is_derived_again(own_cache, derivations, capsys):
    assert main(VDP) == 0
    out = capsys.readouterr().out
    (path,) = (own_cache / printed.NAMESPACE).glob("*.json")
    path.write_text(path.read_text().replace("saddle-node in mu", "saddle-node in nu"))
    assert main(VDP) == 0 and len(derivations) == 2
    captured = capsys.readouterr()
    assert captured.out == out and "does not match its sha256 digest" in captured.err


def test_a_forged_printed_entry_with_terminal_codes_is_derived_again(own_cache, derivations, capsys):
    """An entry edited with its digest recomputed passes the digest, but this code never prints a control
    character: text holding one (a terminal escape) is damage, derived again, never sent to the terminal."""
    from pulsemap.symbolic import cache

    assert main(VDP) == 0
    out = capsys.readouterr().out
    (path,) = (own_cache / printed.NAMESPACE).glob("*.json")
    entry = json.loads(path.read_text())
    entry["value"]["printed"] = "\x1b]0;owned\x07\x1b[2J" + entry["value"]["printed"]
    entry["sha256"] = cache.digest(entry["value"])
    path.write_text(json.dumps(entry))
    assert main(VDP) == 0 and len(derivations) == 2
    captured = capsys.readouterr()
    assert captured.out == out and "\x1b" not in captured.out + captured.err
    assert "control character '\\x1b'" in captured.err and captured.err.count("\n") == 1


def test_a_failed_derivation_is_not_stored(own_cache, derivations, capsys):
    for _ in range(2):
        assert main(["derive", "-mu*v", "--param", "mu=1", "--fold", "nu"]) == 2
        assert "nu" in capsys.readouterr().err
    assert len(derivations) == 2 and not list(own_cache.glob(f"{printed.NAMESPACE}/*.json"))


def test_the_json_is_stored_only_once_asked_for(own_cache, derivations, tmp_path, capsys):
    """Printing the JSON costs up to seconds for a large R: a run without --json does not pay it."""
    assert main(VDP) == 0 and main(VDP) == 0 and len(derivations) == 1
    for name, count in (("a.json", 2), ("b.json", 2)):  # the first --json derives again, then it is read back
        assert main(VDP + ["--json", str(tmp_path / name)]) == 0 and len(derivations) == count
    a, b = (json.loads((tmp_path / n).read_text()) for n in ("a.json", "b.json"))
    assert {**a, "timings_s": None} == {**b, "timings_s": None} and "cache" in b["timings_s"]
    assert len(set(capsys.readouterr().out.split("Model: map")) - {""}) == 1  # four identical reports


@pytest.mark.parametrize("extra, message", [(["--coefficients", "derived"], "--coefficients applies to the dressed"),
                                            (["--max-seconds", "-1"], "max")])
def test_a_refused_option_is_refused_after_a_stored_derivation_too(extra, message, own_cache, capsys):
    assert main(VDP) == 0
    capsys.readouterr()
    assert main(VDP + extra) == 2
    assert message in capsys.readouterr().err
