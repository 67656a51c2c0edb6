"""Damaged caches and record files: what is read back is checked (schema, finiteness);
a bad cache entry is computed again, a bad record is ignored with a note naming its file and line.
Never a traceback, never a NaN passed on."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import pytest

from conftest import scene_toml, write_scene
from pulsemap.solvers.data.records import encode_record
from pulsemap.symbolic import cache
from pulsemap.solvers.cli.main import main


@pytest.fixture()
def own_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("PULSEMAP_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


INTEGRAL_DAMAGE = {
    "NaN value": lambda v: {**v, "f1": [math.nan, 0.0]},
    "string value": lambda v: {**v, "f1": "2.59"},
    "negative error bound": lambda v: {**v, "f1": [v["f1"][0], -1.0]},
    "three numbers": lambda v: {**v, "f1": v["f1"] + [1.0]},
    "a list, not a table": lambda v: [1, 2, 3],
    "null": lambda v: None,
}


@pytest.mark.parametrize("how", INTEGRAL_DAMAGE, ids=list(INTEGRAL_DAMAGE))
def test_a_damaged_integral_entry_is_computed_again(how, own_cache, capsys):
    from pulsemap.symbolic.integrals import constants

    fresh = {k: c.value for k, c in constants(["f1", "f2"]).items()}
    (path,) = (own_cache / "integrals").glob("*.json")
    entry = json.loads(path.read_text())
    entry["value"] = INTEGRAL_DAMAGE[how](entry["value"])
    path.write_text(json.dumps(entry))
    capsys.readouterr()
    again = {k: c.value for k, c in constants(["f1", "f2"]).items()}
    assert again == fresh and all(math.isfinite(v) for v in again.values())
    err = capsys.readouterr().err
    if how != "null":  # a null value is no table yet: nothing damaged to say
        assert err.count("\n") == 1 and f"cache entry {path} is damaged" in err and "computing it again" in err
    constants(["f1", "f2"])
    assert capsys.readouterr().err == ""  # repaired: the stored table is whole again


def test_an_entry_that_is_not_json_is_noted_once_and_replaced(own_cache, capsys):
    from pulsemap.symbolic.integrals import constants

    fresh = constants(["f3"])["f3"].value
    (path,) = (own_cache / "integrals").glob("*.json")
    path.write_bytes(b'{"key": "\xff')
    capsys.readouterr()
    assert constants(["f3"])["f3"].value == fresh
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not JSON" in err and str(path) in err


@pytest.mark.parametrize("bad", [math.nan, -1.0, "1.2", None, True, [1.0]])
def test_a_damaged_kappa_entry_is_measured_again(bad, own_cache, monkeypatch, capsys):
    from pulsemap.solvers.chain import kappa as kappa_mod

    calls = []

    def measure(exponent, *, rtol):
        calls.append(exponent)
        return {"kappa": 1.25, "contact": 30, "beads": 50, "spread": 0.0, "rtol": rtol}

    monkeypatch.setattr(kappa_mod, "measure_kappa", measure)
    key = kappa_mod.cache_key(1.5, 1e-10)
    cache.store(kappa_mod.NAMESPACE, key, {"kappa": bad})
    assert kappa_mod.kappa(1.5) == 1.25 and calls == [1.5]
    assert "is damaged (kappa = " in capsys.readouterr().err
    assert kappa_mod.kappa(1.5) == 1.25 and calls == [1.5]  # the good value was stored


def test_a_nan_in_sweep_records_is_run_again_not_reported(tmp_path, capsys):
    scene = write_scene(tmp_path, scene_toml("tiny", beads=40, contacts=(16, 30), methods=("dns",)))
    out, report = tmp_path / "points.jsonl", tmp_path / "report.json"
    argv = ["sweep", str(scene), "--over", "perturbation.eps=0.05,0.1", "--workers", "1", "--quiet",
            "--out", str(out), "--json", str(report)]
    assert main(argv) == 0
    first = json.loads(report.read_text())
    lines = out.read_text().splitlines()
    rec = json.loads(lines[1])
    rec.pop("sha256")
    rec["result"]["live_contacts"] = math.nan
    lines[1] = encode_record(rec)  # NaN, with a right digest: valid for Python's json, not for the report
    out.write_text("\n".join(lines) + "\n")
    capsys.readouterr()
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert f"{out}:2: result.live_contacts is not a finite number: record ignored" in err
    second = json.loads(report.read_text(), parse_constant=lambda c: pytest.fail(f"{c} in the report"))
    assert second["computed"] == 1 and second["skipped"] == 1
    assert [r["live_contacts"] for r in second["points"]] == [r["live_contacts"] for r in first["points"]]


def test_a_non_utf8_line_in_a_rows_file_names_the_file_and_line(tmp_path, capsys):
    from pulsemap.solvers.studies.table import COLUMNS, read_rows, table

    scene = write_scene(tmp_path, scene_toml("tiny", beads=40, contacts=(16, 30)))
    rows_file = tmp_path / "rows.jsonl"
    (row,) = table([str(scene)], rows_file=rows_file, columns=COLUMNS[:1])
    good = rows_file.read_bytes()
    for damage in (b'{"scene": "\xff"}\n', encode_record({**row, "live": "many"}).encode() + b"\n",
                   encode_record({**row, "winner": {"model": "map", "rms_pct": "small"}}).encode() + b"\n"):
        rows_file.write_bytes(damage + good)  # line 1 damaged, line 2 the good row
        capsys.readouterr()
        assert list(read_rows(rows_file).values()) == [row]
        err = capsys.readouterr().err
        assert err.startswith(f"pulsemap: note: {rows_file}:1: ") and err.count("\n") == 1


# --------------------------------------------------------------------------- digests: one digit changed


def _change_one_digit(path, after: str = '"value"') -> str:
    """Change the first digit after a decimal point that follows ``after`` in the file (the JSON stays
    valid, the number stays plausible); returns the changed text."""
    text = path.read_text()
    start = text.index(after)
    j = next(i for i in range(start, len(text) - 1) if text[i] == "." and text[i + 1].isdigit()) + 1
    changed = text[:j] + str((int(text[j]) + 1) % 10) + text[j + 1:]
    path.write_text(changed)
    return changed


def test_one_digit_changed_in_the_cached_integrals_is_computed_again(own_cache, capsys):
    from pulsemap.symbolic.integrals import constants

    fresh = {k: c.value for k, c in constants(["f1", "f2"]).items()}
    (path,) = (own_cache / "integrals").glob("*.json")
    _change_one_digit(path)
    damaged = json.loads(path.read_text())["value"]
    assert {k: v[0] for k, v in damaged.items()} != fresh  # still valid JSON, one number off
    capsys.readouterr()
    assert {k: c.value for k, c in constants(["f1", "f2"]).items()} == fresh
    err = capsys.readouterr().err
    assert err == f"pulsemap: note: cache entry {path} is damaged (its value does not match its sha256 digest): " \
                  "computing it again\n"
    constants(["f1", "f2"])
    assert capsys.readouterr().err == ""  # stored whole again


def test_one_digit_changed_in_the_balance_constants_is_computed_again(own_cache, capsys):
    from pulsemap.symbolic.balance_constants import balance_constants

    fresh = {k: c.value for k, c in balance_constants(["K1", "V1"], n=1.5).items()}
    (path,) = (own_cache / "balance").glob("*.json")
    _change_one_digit(path)
    capsys.readouterr()
    assert {k: c.value for k, c in balance_constants(["K1", "V1"], n=1.5).items()} == fresh
    err = capsys.readouterr().err
    assert "does not match its sha256 digest" in err and str(path) in err and err.count("\n") == 1


def test_one_digit_changed_in_a_relaxed_spline_is_fitted_again(own_cache, capsys):
    """Knots edited out of order would give scipy's 'Knots must be in a non-decreasing order.'; the
    digest (and, for an entry written with a right digest, the spline check) refuses it first."""
    import numpy as np

    from pulsemap.solvers.models.relaxed_table import NAMESPACE, bulk_fit_key, cached_smoothing_spline

    x = np.linspace(0.0, 1.0, 12)
    y, w = np.sin(3 * x), np.ones_like(x)
    fresh = cached_smoothing_spline(x, y, w)(x)
    (path,) = (own_cache / NAMESPACE).glob("*.json")
    _change_one_digit(path)
    capsys.readouterr()
    np.testing.assert_array_equal(cached_smoothing_spline(x, y, w)(x), fresh)
    assert "does not match its sha256 digest" in capsys.readouterr().err
    entry = cache.load(NAMESPACE, bulk_fit_key(x, y, w))
    entry["t"][5], entry["t"][6] = entry["t"][6] + 1.0, entry["t"][5]  # out of order, stored with its digest
    cache.store(NAMESPACE, bulk_fit_key(x, y, w), entry)
    np.testing.assert_array_equal(cached_smoothing_spline(x, y, w)(x), fresh)
    err = capsys.readouterr().err
    assert "knots out of order" in err and "Knots must be" not in err


def test_one_digit_changed_in_a_kappa_entry_is_measured_again(own_cache, monkeypatch, capsys):
    from pulsemap.solvers.chain import kappa as kappa_mod

    calls = []
    monkeypatch.setattr(kappa_mod, "measure_kappa", lambda exponent, *, rtol: calls.append(exponent) or {
        "kappa": 1.25, "contact": 30, "beads": 50, "spread": 0.0, "rtol": rtol})
    assert kappa_mod.kappa(1.5) == 1.25 and len(calls) == 1
    (path,) = (own_cache / kappa_mod.NAMESPACE).glob("*.json")
    _change_one_digit(path)
    assert kappa_mod.kappa(1.5) == 1.25 and len(calls) == 2
    assert "does not match its sha256 digest" in capsys.readouterr().err


def _only_entry(namespace: str):
    """The file of the one entry stored in ``namespace`` of the test's own cache."""
    [path] = (cache.cache_dir() / namespace).glob("*.json")
    return path


@pytest.mark.parametrize("namespace", ["integrals", "balance", "kappa", "relaxed", "dressed", "dressed-derived"])
def test_no_changed_character_of_an_entry_is_served(namespace, own_cache, capsys):
    """Property: every single-character change of an entry's file (each digit, each letter of the
    digest, the key) gives back the stored value or nothing, never another value."""
    value = {"x": [2.589940123, 1e-12], "y": [0.5, 3.0], "k": 3}
    cache.store(namespace, "some key", value)
    path = _only_entry(namespace)
    text = path.read_text()
    served = 0
    for j, ch in enumerate(text):
        if not ch.isalnum():
            continue
        path.write_text(text[:j] + ("7" if ch != "7" else "8") + text[j + 1:])
        got = cache.load(namespace, "some key", quiet=True)
        assert got is None or got == value, (j, text)
        served += got is not None
    assert served == 0  # every character matters: the key, the value or the digest
    path.write_text(text)
    assert cache.load(namespace, "some key") == value


def test_an_entry_without_a_digest_is_computed_again(own_cache, capsys):
    cache.store("kappa", "k", {"kappa": 1.0})
    path = _only_entry("kappa")
    path.write_text(json.dumps({"key": "k", "value": {"kappa": 1.0}}))
    assert cache.load("kappa", "k") is None
    assert "no digest of its value" in capsys.readouterr().err


def test_one_digit_changed_in_a_sweep_record_is_run_again(tmp_path, capsys):
    from pulsemap.solvers.studies.sweep import run_sweep

    out = tmp_path / "points.jsonl"
    first = run_sweep(_square, [{"x": 1.5}, {"x": 2.5}], out, max_workers=1)
    lines = out.read_text().splitlines()
    rec = json.loads(lines[1])
    lines[1] = lines[1].replace(json.dumps(rec["result"]["y"]), json.dumps(rec["result"]["y"] + 0.001))
    assert lines[1] != out.read_text().splitlines()[1]
    out.write_text("\n".join(lines) + "\n")
    capsys.readouterr()
    again = run_sweep(_square, [{"x": 1.5}, {"x": 2.5}], out, max_workers=1)
    assert (again.computed, again.skipped) == (1, 1) and again.results() == first.results()
    assert capsys.readouterr().err == (f"pulsemap: note: {out}:2: the record does not match its sha256 digest "
                                       "(the line was changed): record ignored (its point is computed again)\n")


def _square(params: dict) -> dict:
    return {"y": params["x"] ** 2}


def test_one_digit_changed_in_a_table_row_is_computed_again(tmp_path, monkeypatch, capsys):
    from pulsemap.solvers.studies import table as table_mod

    calls = []

    def fake_row(name, columns=table_mod.COLUMNS, eps=None, sets=(), scene=None, progress=False):
        calls.append(name)
        return {"scene": name, "key": table_mod.row_key(scene.as_dict(), columns), "R": "-mu*v", "eps": 0.1,
                "v0": 1.0, "live": 3, "errors": {"map/exact/paper": {"max_rel_all": 0.0123, "rms_rel_all": 0.0045}},
                "winner": {"model": "map/exact/paper", "rms_rel": 0.0045}}

    monkeypatch.setattr(table_mod, "scene_row", fake_row)
    rows_file = tmp_path / "rows.jsonl"
    first = table_mod.table(["fig8-eps0.1"], rows_file=rows_file, workers=1)
    rows_file.write_text(rows_file.read_text().replace("0.0123", "0.0124"))
    capsys.readouterr()
    assert table_mod.table(["fig8-eps0.1"], rows_file=rows_file, workers=1) == first and len(calls) == 2
    assert f"{rows_file}:1: the record does not match its sha256 digest" in capsys.readouterr().err


# --------------------------------------------------------------------------- the cache path is not a file


@pytest.mark.parametrize("kind", ["directory", "FIFO", "symlink to /dev/zero"])
def test_a_cache_entry_that_is_not_a_file_is_bypassed(kind, own_cache, capsys):
    import os

    from pulsemap.symbolic.integrals import constants

    fresh = constants(["f1"])["f1"].value
    (path,) = (own_cache / "integrals").glob("*.json")
    path.unlink()
    {"directory": path.mkdir, "FIFO": lambda: os.mkfifo(path),
     "symlink to /dev/zero": lambda: path.symlink_to("/dev/zero")}[kind]()
    capsys.readouterr()
    assert constants(["f1"])["f1"].value == fresh  # returns at once: no blocking open, no endless read
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"cache path {path} is " in err and "working without it" in err
    assert not list(path.parent.glob("*.tmp"))


def test_the_cli_runs_past_a_folder_where_a_cache_entry_goes(own_cache, capsys):
    assert main(["derive", "-mu*v", "--param", "mu=1", "--sympy-seconds", "0", "--quiet"]) == 0
    out = capsys.readouterr().out
    paths = list(own_cache.glob("*/*.json"))  # the integrals and the printed derivation
    assert {p.parent.name for p in paths} >= {"integrals", "derivation"}
    for path in paths:
        path.unlink()
        path.mkdir()
    assert main(["derive", "-mu*v", "--param", "mu=1", "--sympy-seconds", "0", "--quiet"]) == 0
    captured = capsys.readouterr()
    assert captured.out == out and "is a directory, not a regular file: working without it" in captured.err
    assert f"{own_cache / 'integrals'}" in captured.err  # derived again past the printed entry, not read


# --------------------------------------------------------------------------- a full disk


@pytest.fixture()
def full_disk(tmp_path):
    """A 64 kB tmpfs filled up to its last bytes (needs root and mount; skipped with the reason otherwise)."""
    import os
    import subprocess

    mnt = tmp_path / "small"
    mnt.mkdir()
    if os.geteuid() != 0:
        pytest.skip("a full disk needs a small tmpfs, and mounting one needs root")
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(mnt)], capture_output=True, text=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs here: {done.stderr.strip() or done.returncode}")
    try:
        (mnt / "old.json").write_text('{"old": true}\n')
        with open(mnt / "filler", "wb", buffering=0) as fh:  # fill every block
            try:
                while True:
                    fh.write(b"x" * 1024)
            except OSError:
                pass
        yield mnt
    finally:
        subprocess.run(["umount", str(mnt)], check=False)


def test_a_document_on_a_full_disk_keeps_the_old_file(full_disk, capsys):
    from pulsemap.solvers.cli.common import write_text
    from pulsemap.symbolic.files import WriteError

    target = full_disk / "old.json"
    with pytest.raises(WriteError) as info:
        write_text(str(target), "x" * 100_000)
    message = str(info.value)
    assert str(target) in message and "No space left on device" in message and "free some space" in message
    assert target.read_text() == '{"old": true}\n'  # not truncated
    assert sorted(p.name for p in full_disk.iterdir()) == ["filler", "old.json"]  # no temporary left


def test_the_cli_says_which_file_a_full_disk_stopped(full_disk, capsys):
    target = full_disk / "old.json"
    assert main(["profile", "--json", str(target)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"pulsemap: error: cannot write the document {target}: ")
    assert "No space left on device" in err and "free some space" in err and "[Errno" not in err
    assert target.read_text() == '{"old": true}\n'
    assert sorted(p.name for p in full_disk.iterdir()) == ["filler", "old.json"]


def test_a_full_cache_disk_is_noted_and_leaves_no_temporary(full_disk, monkeypatch, capsys):
    monkeypatch.setenv("PULSEMAP_CACHE_DIR", str(full_disk / "cache"))
    try:
        cache.cache_dir()
    except cache.CacheDirError:
        pytest.skip("not even the cache folder fits on the full tmpfs")
    cache.store("kappa", "big", {"values": [1.5] * 20_000})
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot be written (No space left on device)" in err
    assert cache.load("kappa", "big") is None
    assert not [p for p in (full_disk / "cache").rglob("*") if p.is_file()]


# --------------------------------------------------------------------------- numba's own cache files


NUMBA_CALLERS = {
    "command": ("from pulsemap.solvers.data.numba_cache import call_recovering_numba_cache\n"
                "print(call_recovering_numba_cache(lambda a: int(kern.twice(21.0)), argparse.Namespace()))\n"),
    "sweep worker": ("from pulsemap.solvers.studies.sweep import _call\n"
                     "print(int(_call(lambda p: {'y': kern.twice(p['x'])}, {'x': 21.0})['result']['y']))\n"),
}


@pytest.mark.parametrize("caller", NUMBA_CALLERS)
def test_damaged_numba_cache_files_are_removed_and_the_kernel_compiled_again(caller, tmp_path):
    """numba unpickles its index and data files and lets the error through (a traceback on every run
    until they are deleted); the guard of a command and of a sweep worker removes them, says so in
    one line and runs again."""
    import subprocess
    import sys

    (tmp_path / "kern.py").write_text("from numba import njit\n\n@njit(cache=True)\ndef twice(x):\n    return 2.0 * x\n")
    script = "import sys, argparse; sys.path.insert(0, sys.argv[1]); import kern\n" + NUMBA_CALLERS[caller]
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}

    def run():
        return subprocess.run([sys.executable, "-c", script, str(tmp_path)], capture_output=True, text=True,
                              env=env, timeout=300)

    first = run()
    assert first.returncode == 0 and first.stdout == "42\n", first.stderr
    files = [p for p in (tmp_path / "numba").rglob("*") if p.suffix in (".nbi", ".nbc")]
    assert files
    for path in files:
        path.write_bytes(os.urandom(64))
    damaged = run()
    assert damaged.returncode == 0 and damaged.stdout == "42\n", damaged.stderr
    assert damaged.stderr.count("\n") == 1 and "numba's compiled-code cache in " in damaged.stderr
    assert "is damaged (" in damaged.stderr and "compiling the kernels again" in damaged.stderr
    again = run()
    assert again.returncode == 0 and again.stdout == "42\n" and again.stderr == ""  # rewritten whole


NUMBA_DAMAGE = {
    "random bytes": lambda p: p.write_bytes(os.urandom(64)),
    "emptied .nbc": lambda p: p.write_bytes(b"") if p.suffix == ".nbc" else None,
    "truncated": lambda p: p.write_bytes(p.read_bytes()[: p.stat().st_size // 2]),
}


@pytest.mark.process
@pytest.mark.parametrize("place", ["NUMBA_CACHE_DIR", "default"])
def test_a_run_past_damaged_kernel_caches_gives_the_same_peaks(place, tmp_path):
    """pulsemap's real kernels (the JIT chain kernel and a generated numba force), their cache files damaged
    every way in turn, at numba's default place in the pulsemap cache or under NUMBA_CACHE_DIR: exit 0,
    one note per damaged folder, the peaks of the undamaged run (--csv -: the report goes to stderr)."""
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["PULSEMAP_CACHE_DIR"] = str(tmp_path / "cache")
    folder = tmp_path / "cache" / "numba"
    if place == "NUMBA_CACHE_DIR":
        env["NUMBA_CACHE_DIR"] = str(folder := tmp_path / "numba")
    argv = [sys.executable, "-m", "pulsemap.solvers.cli.main", "run", "default", "--methods", "dns", "--set",
            "perturbation.R=-mu*sin(v)", "--quiet", "--csv", "-"]

    def run():
        return subprocess.run(argv, capture_output=True, text=True, env=env, timeout=600)

    first = run()
    assert first.returncode == 0, first.stderr
    entries = sorted(folder.rglob("*.nbi"))
    assert len({p.parent for p in entries}) == 2  # the chain kernels and the generated force
    for how, damage in NUMBA_DAMAGE.items():
        for path in folder.rglob("*.nb?"):
            damage(path)
        damaged = run()
        assert damaged.returncode == 0, (how, damaged.stderr)
        assert damaged.stdout == first.stdout, how
        notes = [line for line in damaged.stderr.splitlines() if line.startswith("pulsemap:")]
        assert len(notes) == 2 and all("numba's compiled-code cache in " in n and "is damaged (" in n
                                       for n in notes), (how, notes)
        assert "Traceback" not in damaged.stderr
    clean = run()
    assert clean.returncode == 0 and clean.stdout == first.stdout and "pulsemap:" not in clean.stderr


def _temporary_generated() -> set:
    import tempfile
    from pathlib import Path

    return set(Path(tempfile.gettempdir()).glob("pulsemap-generated-*"))


GENERATED_RUNS = {  # each makes the module kinds named: the map and balance (Eq. 23, energy), the numpy force
    "map": ["--methods", "map,energy-map", "--set", "perturbation.R=-mu*v-0.1234*u^3"],
    "force": ["--methods", "energy-map", "--set", "perturbation.R=-mu*sin(0.987*v)"],
}


@pytest.mark.parametrize("kind", GENERATED_RUNS)
@pytest.mark.parametrize("blocked", ["a folder where each module goes", "a file where generated/ goes"])
def test_a_generated_module_whose_place_is_taken_is_built_in_a_private_temporary_folder(kind, blocked, own_cache,
                                                                                          capsys):
    """As the cache's data files are: the run goes on with a note per blocked path, the same peaks, and no
    temporary folder left behind."""
    argv = ["run", "default", *GENERATED_RUNS[kind], "--quiet", "--csv", "-"]
    assert main(argv) == 0
    good = capsys.readouterr().out
    modules = sorted((own_cache / "generated").glob("*.py"))
    assert any(p.name.startswith(kind) for p in modules)
    if blocked.startswith("a folder"):
        for path in modules:
            path.unlink()
            path.mkdir()
        expected = [f"cache path {p} is a directory, not a regular file: working without it" for p in modules]
    else:
        for path in modules:
            path.unlink()
        (own_cache / "generated").rmdir()
        (own_cache / "generated").write_text("not a folder")
        expected = [f"cache path {own_cache / 'generated'} cannot be used"]
    before = _temporary_generated()
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert captured.out == good
    notes = [line for line in captured.err.splitlines() if line.startswith("pulsemap:")]  # --csv -: report on stderr
    assert len(notes) == len(expected) and all(any(e in n for n in notes) for e in expected), notes
    assert _temporary_generated() <= before


def test_a_file_where_a_cache_namespace_goes_is_bypassed(own_cache, capsys):
    from pulsemap.symbolic.integrals import constants

    own_cache.mkdir(parents=True)
    (own_cache / "integrals").write_text("not a folder")
    first = constants(["f1"])["f1"].value
    assert constants(["f1"])["f1"].value == first
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"cache path {own_cache / 'integrals'} cannot be used" in err


def test_temporaries_a_killed_run_left_are_removed_by_the_next_run_a_day_on(own_cache, tmp_path, monkeypatch, capsys):
    """A process killed (SIGKILL) between writing a cache entry's temporary and renaming it leaves the
    temporary; the next command removes it once it is a day old, and nothing younger or not ours."""
    import signal
    import subprocess
    import sys
    import time

    monkeypatch.setattr("tempfile.tempdir", str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    script = ("import os, signal\nfrom pulsemap.symbolic import cache\n"
              "os.replace = lambda *a: os.kill(os.getpid(), signal.SIGKILL)\n"
              "cache.store('kappa', 'killed', {'values': [1.5]})\n")
    killed = subprocess.run([sys.executable, "-c", script], env={**os.environ, "PULSEMAP_CACHE_DIR": str(own_cache)},
                            capture_output=True, timeout=120)
    assert killed.returncode == -signal.SIGKILL
    (left,) = [p for p in own_cache.rglob("*") if p.is_file()]
    import tempfile

    young = Path(tempfile.mkstemp(dir=left.parent, prefix=left.name.split(".tmp")[0][:-8], suffix=".tmp")[1])
    numba_tmp = own_cache / "numba" / "chain_x" / "k.run-77.py311.nbi.tmp.0123456789abcdef"  # numba's own naming
    (own_cache / "numba" / "aot").mkdir(parents=True)
    build = Path(tempfile.mkdtemp(prefix=".pulsemap_rk45_dense_0123-", dir=own_cache / "numba" / "aot"))
    bypass = Path(tempfile.mkdtemp(prefix="pulsemap-generated-"))
    keep = own_cache / "kappa" / "kept.json"
    numba_tmp.parent.mkdir(parents=True)
    numba_tmp.write_bytes(b"x")
    keep.write_text("{}")
    day_ago = time.time() - 25 * 3600
    for path in (left, numba_tmp, build, bypass, keep):
        os.utime(path, (day_ago, day_ago))
    assert main(["scenes"]) == 0
    capsys.readouterr()
    assert not left.exists() and not numba_tmp.exists() and not build.exists() and not bypass.exists()
    assert young.exists() and keep.exists()
