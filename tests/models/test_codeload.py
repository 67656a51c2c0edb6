"""Damaged generated modules: the cache's copy is regenerated with a note on stderr,
the package's copy is refused with a message naming the file; nothing escapes as a traceback."""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from pulsemap.symbolic import codegen
from pulsemap.symbolic.sources import ForceSource, module_name
from pulsemap.solvers.models import codeload
from pulsemap.solvers.models.codeload import GeneratedModuleError, force_module, load_by_name

R, PARAMS = "-mu*v - 0.25*u^3", ("mu",)


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("PULSEMAP_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache" / "generated"


def _force_values(mod):
    u, v = np.linspace(-1, 1, 7), np.linspace(-2, 2, 7)
    return np.asarray(mod.force(u, v, np.arange(1, 8), 0.1, 1.3), dtype=float)


def _damage(path, how):
    text = path.read_bytes()
    if how == "edited":
        path.write_bytes(text.replace(b"0.25", b"0.5"))
    elif how == "one digit":
        path.write_bytes(text.replace(b"0.25", b"0.26"))
    elif how == "truncated":
        path.write_bytes(text[: len(text) // 3])
    elif how == "random bytes":
        path.write_bytes(np.random.default_rng(0).integers(0, 256, 4000, dtype=np.uint8).tobytes())
    elif how == "empty":
        path.write_bytes(b"")
    elif how == "another module":
        other = next(codegen.PACKAGE_DIR.glob("force_*.py"))
        shutil.copyfile(other, path)
    else:  # pragma: no cover
        raise AssertionError(how)


HOW = ["edited", "one digit", "truncated", "random bytes", "empty", "another module"]


@pytest.mark.parametrize("how", HOW)
def test_a_damaged_cached_module_is_regenerated_with_one_line_on_stderr(how, cache, capsys):
    good = force_module(R, PARAMS)
    expected = _force_values(good)
    path = cache / (module_name(ForceSource.of(R, PARAMS)) + ".py")
    assert path.is_file() and capsys.readouterr().err == ""
    original = path.read_bytes()
    _damage(path, how)
    again = force_module(R, PARAMS)
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"pulsemap: note: cached module {path} was damaged (")
    assert "regenerating it" in err
    assert path.read_bytes() == original  # regenerated: the same text as before
    np.testing.assert_array_equal(_force_values(again), expected)
    force_module(R, PARAMS)
    assert capsys.readouterr().err == ""  # repaired once, then quiet


@pytest.mark.parametrize("how", HOW)
def test_a_damaged_shipped_module_is_refused_naming_the_file(how, cache, tmp_path, monkeypatch):
    shipped = tmp_path / "generated"
    path = codegen.write(ForceSource.of(R, PARAMS), shipped)
    monkeypatch.setattr(codeload, "PACKAGE_DIR", shipped)
    np.testing.assert_allclose(_force_values(force_module(R, PARAMS)), _force_values(force_module(R, PARAMS)))
    _damage(path, how)
    with pytest.raises(GeneratedModuleError) as info:
        force_module(R, PARAMS)
    message = str(info.value)
    assert "\n" not in message and str(path) in message and "shipped" in message and "reinstall" in message
    assert not (cache / path.name).exists()  # refused, not silently replaced by a cache copy
    with pytest.raises(GeneratedModuleError, match=f"{path} is damaged"):
        load_by_name(path.stem)


def test_the_cli_reports_a_damaged_shipped_module_in_one_line(cache, tmp_path, monkeypatch, capsys):
    from conftest import scene_toml, write_scene
    from pulsemap.solvers.cli.main import main

    scene = write_scene(tmp_path, scene_toml("damaged", beads=40, methods=("dns",)))
    shipped = tmp_path / "generated"
    path = codegen.write(ForceSource.of("-mu*v", ("mu",)), shipped)
    monkeypatch.setattr(codeload, "PACKAGE_DIR", shipped)
    _damage(path, "truncated")
    assert main(["run", str(scene), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("pulsemap: error: generated module ") and str(path) in err
    assert os.path.getsize(path) > 0


@pytest.mark.process
def test_a_refused_balance_model_is_refused_again_without_sympy(tmp_path):
    """Momentum balance with a foundation term (-u) is undefined (derive/balance.py): the second process
    finds the reason in the cache and raises the same BalanceError without importing sympy."""
    import subprocess
    import sys

    code = ("import sys\nfrom pulsemap.solvers.models.codeload import balance_module\n"
            "try:\n    balance_module('-u + mu*v', ['mu'], 1.5, 'exact', 'momentum')\n"
            "except Exception as exc:\n    print(type(exc).__name__, 'sympy' in sys.modules, exc)\n")
    env = {**os.environ, "PULSEMAP_CACHE_DIR": str(tmp_path / "cache")}
    first, second = (subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                                    check=True).stdout.strip() for _ in range(2))
    assert first.startswith("BalanceError True ") and "undefined" in first
    assert second == first.replace("BalanceError True ", "BalanceError False ", 1)


def test_a_generated_module_is_executed_once_per_process_and_a_failed_execution_leaves_the_loaded_one(tmp_path,
                                                                                                     monkeypatch):
    """codeload._exec: the same file gives the same module object (each segment run of a relaxed table asks again);
    a file of the same name at another path is executed on its own; one whose execution fails leaves the module
    this process had under that name."""
    first = codeload.force_module("-mu*v", ("mu",))
    assert codeload.force_module("-mu*v", ("mu",)) is first
    key = codeload._module_key(Path(first.__file__).stem)
    assert sys.modules[key] is first
    elsewhere = tmp_path / Path(first.__file__).name
    elsewhere.write_text(Path(first.__file__).read_text(encoding="utf-8"), encoding="utf-8")
    other = codeload._exec(elsewhere)
    assert other is not first and other.__file__ == str(elsewhere)
    broken = tmp_path / "broken" / elsewhere.name
    broken.parent.mkdir()
    broken.write_text("raise RuntimeError('generated code that fails')\n", encoding="utf-8")
    monkeypatch.setitem(sys.modules, key, first)
    with pytest.raises(RuntimeError, match="generated code that fails"):
        codeload._exec(broken)
    assert sys.modules[key] is first
