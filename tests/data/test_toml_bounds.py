"""Bounds on scene files checked before parsing (solvers/data/scene/toml_bounds.py)."""

from __future__ import annotations

from pulsemap.solvers.data.scene.files import tomllib  # tomllib or, on Python 3.10, tomli
from importlib import resources

import pytest

from conftest import scene_toml, write_scene
from pulsemap.solvers.data.scene import toml_bounds
from pulsemap.solvers.data.scene import SceneError, load_scene
from pulsemap.solvers.data.scene.toml_bounds import (MAX_DEPTH, MAX_KEY_CHARS, MAX_KEY_PARTS, TomlBoundsError,
                                               check_toml_bounds)

BASE = scene_toml("bounds", beads=40)


def test_every_shipped_scene_is_within_the_bounds():
    folder = resources.files("pulsemap.solvers.data") / "scenes"
    texts = [p.read_text() for p in folder.iterdir() if p.name.endswith(".toml")]
    texts += [p.read_text() for p in (folder / "suite").iterdir() if p.name.endswith(".toml")]
    assert len(texts) > 20
    for text in texts:
        check_toml_bounds(text)


TRICKY = '''
a = "[[[[[[[[[[[[[[[[[[[[ { , = # not a comment \\" still a string"
b = '[[[[[[[[[[[[[[[[[[[[ literal \\'
c = """
[[[[[[[[[[[[[[[[[[[[[[[[[[[ a.b.c.d.e.f.g.h.i.j = 1
"""
d = \'\'\'[[[[[[[[[[[[[[[[[[[[[[[[[\'\'\'
# [[[[[[[[[[[[[[[[[[[[[[[[[[[[ a.b.c.d.e.f.g.h.i.j = 1
"e.f.g.h.i.j.k.l.m.n" = 1
t = {x.y = [1, [2, {z = 3}]], w = {}}
[[arr.of.tables]]
q = 1.5e3
'''


def test_strings_comments_and_quoted_dots_are_not_counted():
    tomllib.loads(TRICKY)  # valid TOML
    check_toml_bounds(TRICKY)


@pytest.mark.parametrize("kind", ["array", "inline table"])
def test_depth_at_the_bound_passes_and_one_more_is_refused(kind):
    def nest(depth):
        if kind == "array":
            return "x = " + "[" * depth + "1" + "]" * depth + "\n"
        return "x = " + "{a = " * depth + "1" + "}" * depth + "\n"

    tomllib.loads(nest(MAX_DEPTH))
    check_toml_bounds(nest(MAX_DEPTH))
    with pytest.raises(TomlBoundsError, match=f"nested more than {MAX_DEPTH} deep"):
        check_toml_bounds(nest(MAX_DEPTH + 1))


@pytest.mark.parametrize("template", ["{key} = 1\n", "[{key}]\n", "[[{key}]]\n", "t = {{{key} = 1}}\n"])
def test_key_parts_and_length_bounds(template):
    ok = ".".join(["k"] * MAX_KEY_PARTS)
    tomllib.loads(template.format(key=ok))
    check_toml_bounds(template.format(key=ok))
    with pytest.raises(TomlBoundsError, match=f"more than {MAX_KEY_PARTS} parts"):
        check_toml_bounds(template.format(key=".".join(["k"] * (MAX_KEY_PARTS + 1))))
    check_toml_bounds(template.format(key="k" * MAX_KEY_CHARS))
    with pytest.raises(TomlBoundsError, match=f"longer than {MAX_KEY_CHARS}"):
        check_toml_bounds(template.format(key="k" * (MAX_KEY_CHARS + 1)))
    with pytest.raises(TomlBoundsError, match=f"longer than {MAX_KEY_CHARS}"):
        check_toml_bounds(template.format(key='"' + "k" * MAX_KEY_CHARS + '"'))


def test_the_line_is_named():
    with pytest.raises(TomlBoundsError, match="^line 17: "):
        check_toml_bounds(BASE + "\n" + "a." * 20 + "b = 1\n")


def test_syntax_errors_are_left_to_tomllib(tmp_path):
    for bad in ('x = "unterminated\n', "x = ]\n", "] = 1\n", "x = [[[\n"):
        check_toml_bounds(bad)  # no bound exceeded: tomllib reports the syntax
        with pytest.raises(SceneError, match="TOML syntax error"):
            load_scene(write_scene(tmp_path, BASE + bad))


def test_a_file_larger_than_the_bound_is_refused_before_it_is_read(tmp_path, monkeypatch):
    path = write_scene(tmp_path, BASE)
    monkeypatch.setattr(toml_bounds, "MAX_SCENE_BYTES", len(BASE.encode()) - 1)
    with pytest.raises(SceneError, match=rf"{path}: the file is {len(BASE.encode())} bytes, more than"):
        load_scene(path)
    monkeypatch.setattr(toml_bounds, "MAX_SCENE_BYTES", len(BASE.encode()))
    assert load_scene(path).name == "bounds"


def test_the_cases_of_the_issue_are_refused_fast_and_small(tmp_path):
    """500 nested levels (was a RecursionError); a 20,000-part key in a 40 KB file (was 2.4 GB)."""
    import tracemalloc

    for text, needle in ((BASE + "x = " + "[" * 500 + "]" * 500 + "\n", "deep"),
                         (BASE + ".".join(["a"] * 20000) + " = 1\n", "parts")):
        tracemalloc.start()
        with pytest.raises(SceneError, match=needle):
            load_scene(write_scene(tmp_path, text))
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert peak < 10 * len(text) + 2_000_000, peak
