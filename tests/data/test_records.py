"""solvers/records.py: JSON-lines files that survive a run killed mid-write."""

from __future__ import annotations

import math
import re

from pulsemap.solvers.data.records import (append_record, encode_record, open_for_append, read_keyed, read_lines,
                                          write_record)


def test_missing_file_reads_as_empty(tmp_path):
    assert list(read_lines(tmp_path / "absent.jsonl")) == [] and read_keyed(tmp_path / "absent.jsonl") == {}


def test_records_round_trip_and_the_last_of_a_key_wins(tmp_path):
    path = tmp_path / "sub" / "r.jsonl"  # the folder is created
    recs = [{"key": "a", "v": 1}, {"key": "b", "v": [1.5, None]}, {"key": "a", "v": 3}]
    with open_for_append(path) as fh:
        for rec in recs:
            write_record(fh, rec)
    assert list(read_lines(path)) == recs
    assert read_keyed(path) == {"a": recs[2], "b": recs[1]}


def test_skips_blank_non_object_and_keyless_lines(tmp_path):
    path = tmp_path / "r.jsonl"
    lines = ["", "[1, 2]", '"text"', encode_record({"key": 5}), encode_record({"v": 1}),
             encode_record({"key": "k", "v": 2}), "", ""]
    path.write_text("\n".join(lines), encoding="utf-8")
    assert list(read_lines(path)) == [{"key": 5}, {"v": 1}, {"key": "k", "v": 2}]
    assert read_keyed(path) == {"k": {"key": "k", "v": 2}}
    assert read_keyed(path, required=("scene",)) == {}


def test_a_line_cut_by_a_kill_is_skipped_and_the_next_record_starts_a_new_line(tmp_path):
    path = tmp_path / "r.jsonl"
    append_record(path, {"key": "a", "scene": "x"})
    append_record(path, {"key": "b", "scene": "y"})
    with path.open("a", encoding="utf-8") as fh:
        fh.write('{"key": "c", "scene": ')  # the kill: no closing brace, no newline
    assert set(read_keyed(path)) == {"a", "b"}
    append_record(path, {"key": "c", "scene": "z"})
    lines = path.read_text(encoding="utf-8").splitlines()
    assert len(lines) == 4 and lines[2] == '{"key": "c", "scene": '
    assert lines[3] == encode_record({"key": "c", "scene": "z"})
    assert read_keyed(path, required=("scene",))["c"] == {"key": "c", "scene": "z"}
    append_record(path, {"key": "d", "scene": "w"})  # an intact file gets no blank line
    assert len(path.read_text(encoding="utf-8").splitlines()) == 5


def test_a_damaged_line_is_noted_with_file_and_line_and_skipped(tmp_path, capsys):
    """A non-UTF-8 line must name its file and NaN records must not give NaN reports: both are noted and skipped."""
    from pulsemap.solvers.data.records import non_finite_path

    path = tmp_path / "r.jsonl"
    def line(rec: dict) -> bytes:
        return encode_record(rec).encode()

    lines = [line({"key": "a", "v": 1}), b'{"key": "b", "v": "\xff\xfe"}', line({"key": "c", "v": [1, math.nan]}),
             line({"key": "d", "v": {"w": math.inf}}), b"[" * 100000 + b"]" * 100000, line({"key": "e", "v": -math.inf}),
             line({"key": "f", "v": 2}), line({"key": "g", "v": "wrong"}), b'{"key": "cut", "v": ']
    path.write_bytes(b"\n".join(lines))
    recs = list(read_lines(path, check=lambda r: "v is a string" if isinstance(r["v"], str) else None))
    assert [r["key"] for r in recs] == ["a", "f"]
    notes = capsys.readouterr().err.splitlines()
    assert [n.split(": ")[2] for n in notes] == [f"{path}:{k}" for k in (2, 3, 4, 5, 6, 8)]
    assert all(n.startswith("pulsemap: note: ") and n.endswith("record ignored (its point is computed again)")
               for n in notes)
    assert "not UTF-8" in notes[0] and "v[1] is not a finite number" in notes[1]
    assert "v.w is not a finite number" in notes[2] and "nested too deep" in notes[3] and "v is a string" in notes[5]
    assert non_finite_path({"a": [1.0, {"b": float("inf")}]}) == "a[1].b" and non_finite_path({"a": [1, "x"]}) is None


def test_no_changed_character_of_a_record_line_is_served(tmp_path, capsys):
    """Property: every single-character change of a record line gives back the record or nothing
    (noted), never another record: the line carries the sha256 of its record."""
    path = tmp_path / "r.jsonl"
    rec = {"key": "k", "result": {"peaks": [0.5123, 1.25e-3], "status": "ok"}, "elapsed_s": 0.25}
    append_record(path, rec)
    line = path.read_text(encoding="utf-8")
    served = 0
    for j, ch in enumerate(line.rstrip("\n")):
        if not ch.isalnum():
            continue
        path.write_text(line[:j] + ("7" if ch != "7" else "8") + line[j + 1:], encoding="utf-8")
        got = read_keyed(path)
        assert got in ({}, {"k": rec}) or list(got.values()) == [rec], (j, got)
        served += bool(got)
    assert served == 0
    capsys.readouterr()


def test_a_record_without_a_digest_or_with_a_wrong_one_is_noted(tmp_path, capsys):
    path = tmp_path / "r.jsonl"
    path.write_text('{"key": "a", "v": 1}\n' + encode_record({"key": "b", "v": 2}).replace('"v":2', '"v":3') + "\n"
                    + encode_record({"key": "c", "v": 4}) + "\n", encoding="utf-8")
    assert read_keyed(path) == {"c": {"key": "c", "v": 4}}
    notes = capsys.readouterr().err.splitlines()
    assert notes[0].endswith(f"{path}:1: no digest: not written by this pulsemap: record ignored (its point is "
                             "computed again)")
    assert f"{path}:2: the record does not match its sha256 digest" in notes[1] and len(notes) == 2


def test_a_record_file_that_is_not_a_file_is_refused_without_blocking(tmp_path):
    import os

    import pytest

    from pulsemap.solvers.data.records import RecordFileError

    fifo = tmp_path / "fifo.jsonl"
    os.mkfifo(fifo)
    for path, kind in ((fifo, "a FIFO (named pipe)"), ("/dev/zero", "a character device"), (tmp_path, "a directory")):
        with pytest.raises(RecordFileError, match=re.escape(kind)):
            list(read_lines(path))


def test_a_line_longer_than_the_limit_is_skipped_unread(tmp_path, monkeypatch, capsys):
    from pulsemap.solvers.data import records

    monkeypatch.setattr(records, "MAX_LINE_BYTES", 100)
    path = tmp_path / "r.jsonl"
    path.write_text(encode_record({"key": "big", "v": "x" * 500}) + "\n" + encode_record({"key": "s", "v": 1}) + "\n")
    assert read_keyed(path) == {"s": {"key": "s", "v": 1}}
    assert f"{path}:1: longer than 100 bytes" in capsys.readouterr().err
