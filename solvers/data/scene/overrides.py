"""``--set key=value``: change any scene key from the command line, with the scene file's names.

Keys are dotted paths into the scene file (``perturbation.eps``, ``excitation.velocity``,
``chain.beads``, ``output.contacts``, ``perturbation.params.mu``, ``dns.rtol``); values are TOML
values (``0.2``, ``[16, 60]``, ``"exact"``, ``{uniform = [0, 1], seed = 3}``), and a value that
is not TOML is taken as text (``--set perturbation.R=-mu*v``, ``--set model.profile=pade``).
The scene is rebuilt through ``parse_scene``, so an override is checked exactly like the same
value in a file. An unknown key is refused with the closest known key.
"""

from __future__ import annotations

import re
import sys
from typing import Any, Iterable, Mapping

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

from pulsemap.symbolic.errors import closest
from pulsemap.solvers.data.scene.parse import override_changes
from pulsemap.solvers.data.scene.record import recorded_scene
from pulsemap.solvers.data.scene.schema import SceneError
from pulsemap.solvers.data.scene.spec import Scene

PARAMS_PREFIX = "perturbation.params."
#: Keys that name the scene rather than set it (not overridable).
FIXED = ("source",)
#: Keys a scene may set that have no default value in it (absent: the documented default applies).
OPTIONAL = ("dns.engine", "dns.mode", "contact.P", "contact.eps", "contact.first_perturbed", "masses.m",
            "masses.first_perturbed")
PARAMS_TABLES = ("perturbation.params.", "contact.params.", "masses.params.")



def _flat(data: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Dotted key -> value; a parameter (even a table such as a random draw) is one leaf."""
    out: dict[str, Any] = {}
    for key, value in data.items():
        path = prefix + key
        if isinstance(value, Mapping) and not path.startswith(PARAMS_TABLES):
            out.update(_flat(value, path + "."))
        else:
            out[path] = value
    return out


def scene_keys(scene: Scene) -> list[str]:
    """Every key ``--set`` accepts for ``scene`` (its file's keys, defaults and OPTIONAL included)."""
    keys = [k for k in _flat(scene.as_dict()) if k not in FIXED]
    return keys + [k for k in OPTIONAL if k not in keys]


def parse_assignment(text: str) -> tuple[str, Any]:
    """'perturbation.eps=0.2' -> ('perturbation.eps', 0.2); the value as TOML, else as text."""
    if not isinstance(text, str) or "=" not in text:
        raise SceneError(f"--set {shorten(repr(text))}: expected KEY=VALUE with a dotted scene key, e.g. --set perturbation.eps=0.2")
    key, raw = (part.strip() for part in text.split("=", 1))
    if not key or not raw:
        raise SceneError(f"--set {shorten(repr(text))}: expected KEY=VALUE with a dotted scene key, e.g. --set perturbation.eps=0.2")
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw  # plain text: R, a profile name, an expression of i
    return key, value


def check_key(key: str, scene: Scene) -> None:
    """A one-line SceneError for a key the scene file does not have, naming the closest one."""
    known = scene_keys(scene)
    if key in known or key in ("perturbation.params", "contact.params", "masses.params"):  # a whole table
        return
    prefix = next((p for p in PARAMS_TABLES if key.startswith(p)), "")
    name = key[len(prefix):] if prefix else ""
    if name and "." not in name and name.isidentifier():
        return  # a new parameter (for a new R); parse_scene says if R does not use it
    close = closest(key, known)
    hint = f" (did you mean '{close}'?)" if close else ""
    tables = sorted({k.split(".")[0] for k in known if "." in k})
    raise SceneError(f"unknown scene key {key!r}{hint}; keys are dotted paths of the scene file "
                     f"({', '.join(tables)}), e.g. perturbation.eps, excitation.velocity, perturbation.params.mu")


def set_key(data: dict, key: str, value: Any) -> None:
    """data[a][b]... = value for key 'a.b...' (parameters: the name after perturbation.params)."""
    prefix = next((p for p in PARAMS_TABLES if key.startswith(p)), "")
    if prefix:
        parts = [*prefix.split(".")[:2], key[len(prefix):]]
    else:
        parts = key.split(".")
    node = data
    for part in parts[:-1]:
        node = node.setdefault(part, {})
    node[parts[-1]] = value


def apply_overrides(scene: Scene, changes: Iterable[tuple[str, Any]]) -> Scene:
    """``scene`` with each (dotted key, value) applied in order, validated like a scene file: the one
    override mechanism behind ``--set``, ``pulsemap.scene(name, **kw)`` and :func:`with_overrides`.

    Keys are checked against the scene file's (:func:`check_key`); a text key given a number keeps it as
    written (R = 0); tuples are arrays; a new R keeps the parameters it names and those given with it
    and drops the others; the result is rebuilt by ``parse_scene``, or read back from the record of the
    same table (data/scene/record.py). SceneError names the problem.
    """
    items = [(key, list(value) if isinstance(value, tuple) else value) for key, value in changes]
    if not items:
        return scene
    current = _flat(scene.as_dict())
    data = scene.as_dict()
    for key, value in items:
        check_key(key, scene)
        if isinstance(current.get(key), str) and isinstance(value, (int, float)) and not isinstance(value, bool):
            value = _text(value)  # a text key given a number: R = 0, a name 2 (as written, not as parsed)
        set_key(data, key, value)
    new_r = data["perturbation"].get("R")
    if new_r != current.get("perturbation.R") and isinstance(new_r, str) and "perturbation.params" not in dict(items):
        named = set(re.findall(r"[A-Za-z_][A-Za-z0-9_]*", new_r))
        given = {k[len(PARAMS_PREFIX):] for k, _ in items if k.startswith(PARAMS_PREFIX)}
        data["perturbation"]["params"] = {k: v for k, v in data["perturbation"].get("params", {}).items()
                                          if k in named or k in given}
    data.pop("source", None)
    return recorded_scene(data, scene.source or scene.name)


def with_overrides(scene: Scene, **kw: Any) -> Scene:
    """A copy of ``scene`` with some fields replaced, validated like a scene file (:func:`apply_overrides`).

    Keys are the Scene's field names; also ``R``, ``eps`` and ``params`` (raw values, as in a scene
    file) to rebuild the perturbation (a new ``R`` without ``params`` keeps the current
    parameters it uses and drops the others). ``dns`` is merged over the current DNS options.
    """
    return apply_overrides(scene, override_changes(scene, kw))


def with_sets(scene: Scene, assignments: Iterable[str | tuple[str, Any]]) -> Scene:
    """``scene`` with each 'key=value' (or (key, value)) of ``--set`` applied (:func:`apply_overrides`);
    unless the name is set, the name says what was changed (the report shows it)."""
    items = [parse_assignment(a) if isinstance(a, str) else tuple(a) for a in assignments]
    if not items:
        return scene
    shown = ", ".join(f"{k}={shorten(str(v))}" for k, v in items)
    named = [] if any(k == "name" for k, _ in items) else [("name", f"{scene.name} [{shown}]")]
    try:
        return apply_overrides(scene, items + named)
    except SceneError as exc:
        raise SceneError(f"--set {shown}: {exc}") from None


def shorten(text: str, most: int = 40) -> str:
    """``text`` for a one-line message: as it is up to ``most`` characters, else its start and its length."""
    return text if len(text) <= most else f"{text[:most - 16]}... ({len(text)} characters)"


def _text(value: float | int) -> str:
    return str(value) if isinstance(value, int) else repr(value)
