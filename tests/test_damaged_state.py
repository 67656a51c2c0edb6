"""Damaged caches and record files: what is read back is checked (schema, finiteness);
a bad cache entry is computed again, a bad record is ignored with a note naming its file and line.
Never a traceback, never a NaN passed on."""

from __future__ import annotations

import json
import math

import pytest

from conftest import scene_toml, write_scene
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
    rec["result"]["live_contacts"] = math.nan
    lines[1] = json.dumps(rec)  # NaN: valid for Python's json, not for the report
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
    for damage in (b'{"scene": "\xff"}\n', json.dumps({**row, "live": "many"}).encode() + b"\n",
                   json.dumps({**row, "winner": {"model": "map", "rms_pct": "small"}}).encode() + b"\n"):
        rows_file.write_bytes(damage + good)  # line 1 damaged, line 2 the good row
        capsys.readouterr()
        assert list(read_rows(rows_file).values()) == [row]
        err = capsys.readouterr().err
        assert err.startswith(f"pulsemap: note: {rows_file}:1: ") and err.count("\n") == 1
