"""solvers/records.py: JSON-lines files that survive a run killed mid-write."""

from __future__ import annotations

import math

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
    """Issue 14: a non-UTF-8 line named no file; NaN records gave NaN reports. Both are noted and skipped."""
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
