"""Loading scenes: built-in scene files, TOML decoding and the structure check of a parsed table."""

from __future__ import annotations

import difflib
import os
import re
from importlib import resources
from pathlib import Path
from typing import Any, Mapping

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10 (pyproject pulls in tomli)
    import tomli as tomllib  # type: ignore[no-redef]

from pulsemap.solvers.data.scene_checks import _check_consistency, _check_dns_table, _check_fields, _check_name
from pulsemap.solvers.data.scene_params import _build_perturbation
from pulsemap.solvers.data.scene_schema import (
    _EXAMPLES,
    _REQUIRED_KEYS,
    _REQUIRED_TABLES,
    _SCHEMA,
    _TABLES,
    ALIASES,
    DEFAULT_EXPONENT,
    DEFAULT_FIRST_PERTURBED,
    DEFAULT_METHODS,
    DNS_DEFAULTS,
    SceneError,
    _as_table,
    _prefix,
    _Problem,
    _suggest,
    _type_name,
    _unknown,
)
from pulsemap.solvers.data.scene_record import load_record, save_record
from pulsemap.solvers.data.scene_spec import Scene
from pulsemap.solvers.data.toml_bounds import MAX_SCENE_BYTES, TomlBoundsError, check_size, check_toml_bounds
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
            f"unknown built-in scene {name!r}{_suggest(name, names + list(ALIASES))}: "
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
        close = difflib.get_close_matches(stem, names, n=1)
        kind = "suite scene" if close and close[0] in suite_scene_names() else "built-in scene"
        hint = f" (did you mean the {kind} '{close[0]}'?)" if close else ""
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
    """The Scene of a scene file's bytes: its record when this text was parsed before (no sympy,
    data/scene_record.py), else parsed, validated and recorded."""
    scene = load_record(data, source)
    if scene is None:
        scene = parse_scene(_decode(data, source), source)
        save_record(data, source, scene)
    return scene


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


def parse_scene(data: Mapping[str, Any], source: str) -> Scene:
    """Validate an already-parsed TOML table (or :meth:`Scene.as_dict`) and return the Scene."""
    if not isinstance(source, (str, os.PathLike)):
        raise TypeError(f"source must be a string naming where the scene came from (a path or builtin:NAME), "
                        f"got {type(source).__name__}")
    source = str(source)
    name = _default_name(source)
    try:
        if not isinstance(data, Mapping):
            raise _Problem(f"a scene must be a table of tables, got {_type_name(data)}")
        if "name" in data:
            name = _check_name(data["name"])
        _check_structure(data)
        tables = {key: _as_table(data.get(key, {}), key) for key in _TABLES}
        chain, output = tables["chain"], tables["output"]
        raw = {
            "name": name,
            "beads": chain.get("beads"),
            "exponent": chain.get("exponent", DEFAULT_EXPONENT),
            "first_perturbed": chain.get("first_perturbed", DEFAULT_FIRST_PERTURBED),
            "velocity": tables["excitation"]["velocity"],
            "contacts": output["contacts"],
            "methods": output.get("methods", list(DEFAULT_METHODS)),
            "profile": tables["model"].get("profile", "exact"),
            "variant": tables["model"].get("variant", "paper"),
            "dns": _check_dns_table({**DNS_DEFAULTS, **tables["dns"]}),
            "source": source,
        }
        fields = _check_fields(raw)
        fields["perturbation"] = _build_perturbation(tables["perturbation"], name)
        scene = Scene(**fields)
        _check_consistency(scene)
    except _Problem as exc:
        raise SceneError(_prefix(source, name) + str(exc)) from None
    return scene


def _default_name(source: str) -> str:
    if source.startswith("builtin:"):
        return source[len("builtin:"):]
    stem = Path(source).name
    return stem[: -len(".toml")] if stem.endswith(".toml") else (stem or "scene")


def _check_structure(data: Mapping[str, Any]) -> None:
    """Unknown tables and keys (with suggestions), tables given as values, missing keys."""
    for key, value in data.items():
        if key not in _SCHEMA[""]:
            if isinstance(value, Mapping):
                raise _Problem(
                    f"unknown table [{key}]{_suggest(key, _TABLES, '[', ']')}: "
                    f"known tables are {', '.join(f'[{t}]' for t in _TABLES)}"
                )
            raise _Problem(_unknown(key, _SCHEMA[""], "at the top level"))
    for table in _TABLES:
        if table not in data:
            if table in _REQUIRED_TABLES:
                key = _REQUIRED_KEYS[table][0]
                raise _Problem(
                    f"missing table [{table}]: add it with at least "
                    f"{_EXAMPLES.get(f'{table}.{key}', key + ' = ...')}"
                )
            continue
        content = _as_table(data[table], table)
        for key, value in content.items():
            if key not in _SCHEMA[table]:
                if isinstance(value, Mapping):
                    raise _Problem(
                        f"unknown table [{table}.{key}]{_suggest(key, _SCHEMA[table], f'[{table}.', ']')}: "
                        f"[{table}] holds {', '.join(_SCHEMA[table])}"
                    )
                if key in _SCHEMA[""]:
                    raise _Problem(
                        f"key {key!r} is inside [{table}] but belongs at the top level: move it above "
                        f"the first table header{' or write [' + key + '] on its own line' if key in _TABLES else ''}"
                    )
                raise _Problem(_unknown(key, _SCHEMA[table], f"in [{table}]"))
        for key in _REQUIRED_KEYS.get(table, ()):
            if key not in content:
                raise _Problem(
                    f"missing key {key!r} in [{table}]: add {_EXAMPLES.get(f'{table}.{key}', key + ' = ...')}"
                )
    params = _as_table(data["perturbation"], "perturbation").get("params", {})
    if not isinstance(params, Mapping):
        raise _Problem(
            f"[perturbation] params must be a table [perturbation.params] of NAME = VALUE, got {_type_name(params)}"
        )
