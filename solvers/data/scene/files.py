"""Finding scenes: built-in and suite scene lookup by name, and the bounded reading and TOML decoding of a file."""

from __future__ import annotations

import os
import re
from importlib import resources
from pathlib import Path

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10 (pyproject pulls in tomli)
    import tomli as tomllib  # type: ignore[no-redef]

from pulsemap.solvers.data.scene.parse import suggest
from pulsemap.solvers.data.scene.record import recorded_scene
from pulsemap.solvers.data.scene.schema import ALIASES, SceneError
from pulsemap.solvers.data.scene.spec import Scene
from pulsemap.solvers.data.scene.toml_bounds import MAX_SCENE_BYTES, TomlBoundsError, check_size, check_toml_bounds
from pulsemap.symbolic.errors import closest
from pulsemap.symbolic.files import FileKindError, TooLargeError, read_bounded



def builtin_scenes() -> list[str]:
    """Names of the built-in scenes, sorted (the alias ``default`` is not listed)."""
    folder = resources.files("pulsemap.solvers.data").joinpath("scenes")
    return sorted(entry.name[: -len(".toml")] for entry in folder.iterdir() if entry.name.endswith(".toml"))


def suite_scene_names() -> list[str]:
    """Names of the suite's scenes (scenes/suite/: stiff and extreme cases), sorted; runnable by name too."""
    folder = resources.files("pulsemap.solvers.data").joinpath("scenes", "suite")
    return sorted(entry.name[: -len(".toml")] for entry in folder.iterdir() if entry.name.endswith(".toml"))


def named_scenes() -> list[str]:
    """Every name ``load_scene`` accepts: the built-in scenes, the suite's and the alias default."""
    return builtin_scenes() + [n for n in suite_scene_names() if n not in builtin_scenes()] + list(ALIASES)


def builtin_scene_path(name: str):
    """The packaged TOML file of built-in scene ``name`` (an importlib.resources Traversable)."""
    if not isinstance(name, str):
        raise TypeError(f"name must be a string (a built-in scene name), got {type(name).__name__}")
    resolved = ALIASES.get(name, name)
    names = builtin_scenes()
    if resolved not in names:
        raise SceneError(
            f"unknown built-in scene {name!r}{suggest(name, names + list(ALIASES))}: "
            f"choose one of {', '.join(names)} or default"
        )
    return resources.files("pulsemap.solvers.data").joinpath("scenes", f"{resolved}.toml")


def load_scene(ref: str | Path) -> Scene:
    """Load a scene from a path to a ``.toml`` file or from the name of a built-in scene."""
    if not isinstance(ref, (str, os.PathLike)):
        raise TypeError(f"ref must be a scene name or the path of a .toml file (str or Path), got "
                        f"{type(ref).__name__}: for a table use parse_scene(data, source)")
    text = os.fspath(ref)
    if isinstance(text, bytes):
        raise TypeError("ref must be a str or Path, got a bytes path: decode it first")
    looks_like_path = isinstance(ref, Path) or text.endswith(".toml") or "/" in text or "\\" in text
    if not looks_like_path and (text in ALIASES or text in builtin_scenes()):
        resolved = ALIASES.get(text, text)
        source = f"builtin:{resolved}"
        return _parse_file(builtin_scene_path(resolved).read_bytes(), source)
    if not looks_like_path and text in suite_scene_names():  # every named scene runs by its name
        source = f"suite:{text}"
        entry = resources.files("pulsemap.solvers.data").joinpath("scenes", "suite", f"{text}.toml")
        return _parse_file(entry.read_bytes(), source)
    path = Path(text).expanduser()
    if path.is_dir():
        raise SceneError(f"{text}: is a directory, not a scene file: give the path of a .toml file in it")
    if not path.exists():
        names = named_scenes()
        stem = path.name[: -len(".toml")] if path.name.endswith(".toml") else path.name
        close = closest(stem, names)
        kind = "suite scene" if close in suite_scene_names() else "built-in scene"
        hint = f" (did you mean the {kind} '{close}'?)" if close else ""
        raise SceneError(
            f"scene file {text!r} not found{hint}: give the path of a .toml file or a built-in "
            "name (pulsemap scenes lists them)"
        )
    try:
        data = read_bounded(path, MAX_SCENE_BYTES)  # counted in bytes read: /dev/zero has stat size 0
    except FileKindError as exc:
        raise SceneError(f"{text}: {exc.strerror}: give the path of a .toml file") from None
    except TooLargeError:
        raise SceneError(f"{text}: the file is longer than the {MAX_SCENE_BYTES} bytes a scene may have: "
                         "a scene file holds a few tables of numbers") from None
    except OSError as exc:
        raise SceneError(f"{text}: cannot read the scene file ({exc.strerror or exc}): check its permissions") from None
    return _parse_file(data, text)


def _parse_file(data: bytes, source: str) -> Scene:
    """The Scene of a scene file's bytes: its record when this scene was parsed before (no sympy,
    data/scene/record.py), else parsed, validated and recorded."""
    return recorded_scene(_decode(data, source), source)


def _decode(data: bytes, source: str) -> dict:
    """TOML bytes -> table, within the bounds of :mod:`.toml_bounds` (checked before parsing)."""
    try:
        check_size(len(data))
        text = data.decode("utf-8")
        check_toml_bounds(text)
        return tomllib.loads(text)
    except TomlBoundsError as exc:
        raise SceneError(f"{source}: {exc}") from None
    except UnicodeDecodeError as exc:
        raise SceneError(
            f"{source}: not UTF-8 text (byte {exc.start}): save the scene file as UTF-8 TOML"
        ) from None
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{source}: {_toml_reason(str(exc))}") from None


def _toml_reason(message: str) -> str:
    """'Invalid value (at line 3, column 5)' -> 'TOML syntax error at line 3, column 5: ...'."""
    message = " ".join(message.split())
    match = re.match(r"(.*?)\s*\(at (line \d+, column \d+)\)\s*$", message)
    if match:
        return (
            f"TOML syntax error at {match.group(2)}: {match.group(1)}: fix the syntax "
            '(strings in quotes, e.g. R = "-mu*v"; arrays as [16, 120])'
        )
    return f"TOML syntax error: {message}: fix the syntax"
