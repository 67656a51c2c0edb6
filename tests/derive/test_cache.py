"""Where caches and generated code go: the user cache directory, never the installed package (derive/cache.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from pulsemap.symbolic import cache
from pulsemap.solvers.models import codeload


def _snapshot(folder: Path) -> dict[str, int]:
    return {p.name: p.stat().st_mtime_ns for p in folder.iterdir()}


def test_cache_location_rule(monkeypatch, tmp_path):
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.setenv("PULSEMAP_CACHE_DIR", str(tmp_path / "explicit"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache.cache_root() == tmp_path / "explicit"
    monkeypatch.delenv("PULSEMAP_CACHE_DIR")
    assert cache.cache_root() == tmp_path / "xdg" / "pulsemap"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/dir")  # invalid by the XDG spec: ignored
    assert cache.cache_root() == tmp_path / "home" / ".cache" / "pulsemap"
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert cache.cache_root() == tmp_path / "home" / ".cache" / "pulsemap"
    assert cache.cache_dir().is_dir()  # created on demand


def test_a_cached_entry_comes_before_the_shipped_table_which_comes_before_none(monkeypatch, tmp_path):
    """load_or_shipped: the user cache first, then the table shipped with pulsemap; a missing or damaged table
    serves nothing (the dressed law's derived and calibrated coefficients are read this way)."""
    import json

    monkeypatch.setenv("PULSEMAP_CACHE_DIR", str(tmp_path / "cache"))
    table = tmp_path / "shipped.json"
    table.write_text(json.dumps({"both": {"from": "table"}, "table only": {"from": "table"}}), encoding="utf-8")
    cache.store("shipped-test", "both", {"from": "cache"})
    assert cache.load_or_shipped("shipped-test", "both", table) == {"from": "cache"}
    assert cache.load_or_shipped("shipped-test", "table only", table) == {"from": "table"}
    assert cache.load_or_shipped("shipped-test", "neither", table) is None
    damaged = tmp_path / "damaged.json"
    damaged.write_text("{not json", encoding="utf-8")
    assert cache.load_or_shipped("shipped-test", "table only", damaged) is None
    assert cache.load_or_shipped("shipped-test", "table only", tmp_path / "missing.json") is None
    damaged.write_text('["table only"]', encoding="utf-8")  # JSON, but not a table by key
    assert cache.load_or_shipped("shipped-test", "table only", damaged) is None
    cache.store("shipped-test", "falsy", {})  # an empty entry is an entry: the table does not override it
    table.write_text(json.dumps({"falsy": {"from": "table"}}), encoding="utf-8")
    assert cache.load_or_shipped("shipped-test", "falsy", table) == {}


def test_unwritable_cache_is_one_clear_error(monkeypatch, tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("PULSEMAP_CACHE_DIR", str(blocker / "cache"))
    with pytest.raises(cache.CacheDirError) as info:
        cache.cache_dir()
    message = str(info.value)
    assert str(blocker / "cache") in message and "PULSEMAP_CACHE_DIR" in message and "\n" not in message


def test_new_generated_code_goes_to_the_cache_not_the_package(monkeypatch, tmp_path):
    """A perturbation the shipped generated/ lacks is generated into $PULSEMAP_CACHE_DIR/generated."""
    monkeypatch.setenv("PULSEMAP_CACHE_DIR", str(tmp_path))
    shipped = _snapshot(codeload.PACKAGE_DIR)
    mod = codeload.force_module("-mu*v - nu*u^3", ("mu", "nu"))
    assert Path(mod.__file__).parent == tmp_path / "generated"
    assert _snapshot(codeload.PACKAGE_DIR) == shipped


def test_cli_generate_writes_to_the_cache_by_default(monkeypatch, tmp_path, capsys):
    from pulsemap.solvers.cli.main import main

    monkeypatch.setenv("PULSEMAP_CACHE_DIR", str(tmp_path))
    shipped = _snapshot(codeload.PACKAGE_DIR)
    assert main(["generate", "fig8-eps0.3"]) == 0
    written = [Path(line.split("  <- ")[0]) for line in capsys.readouterr().out.splitlines() if "  <- " in line]
    assert written and all(p.parent == tmp_path / "generated" and p.is_file() for p in written)
    assert _snapshot(codeload.PACKAGE_DIR) == shipped
    into = tmp_path / "elsewhere"
    assert main(["generate", "fig8-eps0.3", "--into", str(into)]) == 0
    assert sorted(p.name for p in into.iterdir()) == sorted(p.name for p in written)
