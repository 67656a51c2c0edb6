"""numba's kernel cache lives in the pulsemap user cache (or where NUMBA_CACHE_DIR says), never in the package."""

from __future__ import annotations

import re
from pathlib import Path

import numba
import numpy as np
import pytest

from pulsemap.solvers.chain import compiled_aot, jit

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT  # the editable install's package root: derive/, generated/, solvers/


def test_an_empty_numba_setting_means_the_numba_subfolder_of_the_pulsemap_cache(tmp_path):
    assert compiled_aot.numba_cache_dir("", tmp_path) == tmp_path / "numba"


def test_a_folder_numba_was_given_wins(tmp_path):
    assert compiled_aot.numba_cache_dir(str(tmp_path / "mine"), tmp_path / "pm") == tmp_path / "mine"


@pytest.mark.parametrize("numba_dir", [None, "given"])
def test_configure_follows_the_environment(tmp_path, monkeypatch, numba_dir):
    """PULSEMAP_CACHE_DIR moves the folder; a NUMBA_CACHE_DIR the user set (numba reads it into
    numba.config.CACHE_DIR) takes precedence over it."""
    monkeypatch.setenv("PULSEMAP_CACHE_DIR", str(tmp_path / "pm"))
    monkeypatch.setattr(numba.config, "CACHE_DIR", "" if numba_dir is None else str(tmp_path / numba_dir))
    got = jit.configure()
    want = tmp_path / "pm" / "numba" if numba_dir is None else tmp_path / numba_dir
    assert got == want
    assert numba.config.CACHE_DIR == str(want)
    assert want.is_dir() or numba_dir is not None


def test_an_unwritable_pulsemap_cache_sends_numba_to_the_temporary_folder(tmp_path, monkeypatch, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("PULSEMAP_CACHE_DIR", str(blocker / "below"))
    monkeypatch.setattr(numba.config, "CACHE_DIR", "")
    got = jit.configure()
    assert not str(got).startswith(str(blocker))
    assert not str(got).startswith(str(PACKAGE / "solvers"))
    assert "PULSEMAP_CACHE_DIR" in capsys.readouterr().err
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    assert compiled_aot.folder() == got / "aot"  # the ahead-of-time modules go along


def test_the_kernels_cache_outside_the_package():
    """Each cached dispatcher's folder was fixed when it was decorated: under numba's CACHE_DIR."""
    from pulsemap.solvers.chain import compiled_dop853, compiled_kernel, compiled_stiff, compiled_track
    from pulsemap.solvers.models import map_kernel

    for kernel in (compiled_kernel.run, compiled_kernel.steps, compiled_dop853.run, compiled_stiff.run,
                   compiled_track.track_step, map_kernel.iterate_table):
        path = Path(kernel._cache._cache_path).resolve()
        assert path.is_relative_to(Path(jit.CACHE_DIR).resolve()), (kernel, path)
        assert not path.is_relative_to(PACKAGE / "solvers"), (kernel, path)


DECORATED = re.compile(r"@(njit|jit|cfunc|vectorize|guvectorize)\b|cache\s*=\s*True")


@pytest.mark.parametrize("path", sorted((ROOT / "solvers").rglob("*.py")), ids=lambda p: str(p.relative_to(ROOT)))
def test_every_numba_function_is_defined_after_the_cache_is_configured(path):
    """A module that defines numba functions takes numba's decorators from chain/jit.py, never from numba."""
    text = path.read_text(encoding="utf-8")
    if path.name == "jit.py" or not DECORATED.search(text):
        return
    assert "from pulsemap.solvers.chain.jit import" in text, f"{path.name}: import njit/prange/cfunc from chain/jit.py"
    assert not re.search(r"^from numba import .*\b(njit|jit|cfunc|prange)\b", text, re.M), path.name


def _tiny_kernel(folder: Path):
    """A one-line cached numba function in its own module file (a fresh dispatcher at each call)."""
    import importlib.util

    path = folder / "tiny_kernel.py"
    if not path.exists():
        path.write_text("from pulsemap.solvers.chain.jit import njit\n\n\n@njit(cache=True)\n"
                        "def plus_one(x):\n    return x + 1.0\n", encoding="utf-8")
    spec = importlib.util.spec_from_file_location("pulsemap_test_tiny_kernel", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.plus_one


def test_ready_says_so_once_when_it_compiles_and_nothing_when_the_cache_is_warm(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path / "numba"))
    monkeypatch.setattr(jit, "_announced", False)
    kernel = _tiny_kernel(tmp_path)
    assert jit.ready(kernel, (1.0,)) > 0.0
    assert capsys.readouterr().err.count("compiling the chain kernels, once per machine") == 1
    assert jit.ready(kernel, (1.0,)) == 0.0  # this process has it
    assert kernel(1.0) == 2.0 and kernel.stats.cache_misses  # compiled, not loaded
    assert any((tmp_path / "numba").rglob("*.nbi"))

    monkeypatch.setattr(jit, "_announced", False)
    again = _tiny_kernel(tmp_path)  # a new process's view: the dispatcher is new, the cache is warm
    assert jit.ready(again, (1.0,)) >= 0.0
    assert capsys.readouterr().err == ""
    assert again.stats.cache_hits and not again.stats.cache_misses

    assert jit.ready(again, (1,)) > 0.0  # a new signature: compiled, said once ...
    assert jit.ready(again, (np.int32(1),)) > 0.0  # ... and not again in this process
    assert capsys.readouterr().err.count("compiling") == 1


def test_a_compiled_run_reports_its_kernel_compile_apart_from_the_integration():
    from pulsemap.solvers.chain.dns import Chain, Integrator, simulate

    first = simulate(Chain(40, 1.5, 1.0), (5, 30), window="auto")
    again = simulate(Chain(40, 1.5, 1.0), (5, 30), window="auto")
    assert first.engine == again.engine == "compiled"
    assert first.compile_s >= 0.0 and again.compile_s == 0.0  # this process has the kernel now
    assert np.array_equal(first.peaks, again.peaks) and again.wall_time_s > 0.0
    scipy_run = simulate(Chain(40, 1.5, 1.0), (5, 30), integrator=Integrator(rtol=1e-8, engine="scipy"))
    assert scipy_run.compile_s == 0.0


def _truncate(path: Path) -> None:
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


DAMAGE = {
    "random bytes in .nbi": ("*.nbi", lambda p: p.write_bytes(np.random.default_rng(1).bytes(64))),
    "random bytes in .nbc": ("*.nbc", lambda p: p.write_bytes(np.random.default_rng(2).bytes(64))),
    "emptied .nbc": ("*.nbc", lambda p: p.write_bytes(b"")),
    "truncated .nbi": ("*.nbi", _truncate),
    "truncated .nbc": ("*.nbc", _truncate),
    "unreadable .nbc": ("*.nbc", lambda p: p.chmod(0)),
}


@pytest.mark.parametrize("how", DAMAGE)
def test_a_damaged_cache_entry_is_compiled_again_with_a_note(how, tmp_path, monkeypatch, capsys):
    """Real numba cache files, damaged: the next dispatcher compiles the function anew (no exception),
    says so once, and writes an entry that a third dispatcher loads."""
    import os

    if how.startswith("unreadable") and os.geteuid() == 0:
        pytest.skip("root reads a file without read permission")
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path / "numba"))
    assert _tiny_kernel(tmp_path)(1.5) == 2.5
    pattern, damage = DAMAGE[how]
    files = list((tmp_path / "numba").rglob(pattern))
    assert files
    for path in files:
        damage(path)
    capsys.readouterr()
    again = _tiny_kernel(tmp_path)
    assert again(1.5) == 2.5 and again.stats.cache_misses and not again.stats.cache_hits
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "numba's compiled-code cache in " in err and "is damaged (" in err, err
    assert "compiled again" in err
    third = _tiny_kernel(tmp_path)
    assert third(1.5) == 2.5 and third.stats.cache_hits and not third.stats.cache_misses
    assert capsys.readouterr().err == ""


def test_every_damaged_entry_is_compiled_again_however_many(tmp_path, monkeypatch, capsys):
    """Two functions in one folder, both damaged: one note for the folder, both compiled again."""
    import importlib.util

    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path / "numba"))
    path = tmp_path / "two_kernels.py"
    path.write_text("from pulsemap.solvers.chain.jit import njit\n\n\n@njit(cache=True)\ndef a(x):\n    return x + 1.0\n"
                    "\n\n@njit(cache=True)\ndef b(x):\n    return a(x) * 2.0\n", encoding="utf-8")

    def load():
        spec = importlib.util.spec_from_file_location("pulsemap_test_two_kernels", path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module

    assert load().b(1.0) == 4.0
    files = list((tmp_path / "numba").rglob("*.nb?"))
    assert len([p for p in files if p.suffix == ".nbi"]) == 2
    for p in files:
        p.write_bytes(b"")
    capsys.readouterr()
    fresh = load()
    assert fresh.b(1.0) == 4.0 and fresh.a(1.0) == 2.0
    assert capsys.readouterr().err.count("is damaged (") == 1
    assert all(p.stat().st_size > 0 for p in (tmp_path / "numba").rglob("*.nb?"))


def test_a_folder_where_a_cache_entry_goes_is_bypassed_with_a_note(tmp_path, monkeypatch, capsys):
    """An index file's place taken by a folder: the function is compiled in memory each time, one note."""
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path / "numba"))
    assert _tiny_kernel(tmp_path)(1.5) == 2.5
    (index,) = (tmp_path / "numba").rglob("*.nbi")
    index.unlink()
    index.mkdir()
    capsys.readouterr()
    again = _tiny_kernel(tmp_path)
    assert again(1.5) == 2.5 and again.stats.cache_misses
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"numba's compiled-code cache in {index.parent}" in err, err
    assert index.is_dir()  # not ours to remove
