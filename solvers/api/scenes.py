"""``pulsemap.scene`` and ``pulsemap.scenes``: load a scene (built-in, file or dict) with overrides.

Overrides name a key of the scene file, dotted (``**{"perturbation.eps": 0.2}``,
``**{"perturbation.params.mu": 3}``) or by its last part when that is unambiguous (``eps=0.2``,
``contacts=(16, 60)``, ``mu=3`` for a parameter of R). The scene is then validated as a file is.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

from pulsemap.solvers.api.checks import closest
from pulsemap.solvers.data.scene.overrides import apply_overrides
from pulsemap.solvers.data.scene import Scene, SceneError, builtin_scenes, load_scene, parse_scene
from pulsemap.solvers.data.scene.files import suite_scene_names
from pulsemap.solvers.data.scene.schema import SCHEMA, TABLES

__all__ = ["scene", "scenes"]

#: Every key of a scene file, dotted (the scene file's schema), except the parameters of R.
KEYS = ("name",) + tuple(f"{table}.{key}" for table in TABLES for key in SCHEMA[table])
#: Short names: the last part of each dotted key, the first table's where two share it (eps: perturbation.eps;
#: contact.eps is given dotted).
SHORT = dict(reversed([(key.rsplit(".", 1)[-1], key) for key in KEYS]))


def scenes() -> list[str]:
    """Every scene name :func:`scene` and :func:`pulsemap.run` accept, as ``pulsemap scenes`` lists
    them: the paper's figures and the Van der Pol chains, then the suite's stiff and extreme cases
    (each group sorted; the alias "default" is not listed)."""
    paper = builtin_scenes()
    return paper + [n for n in suite_scene_names() if n not in paper]


def scene(name_or_path: "str | Path | Mapping[str, Any] | Scene", **overrides: Any) -> Scene:
    """A validated scene: a built-in name (:func:`scenes`; "default" too), a path to a ``.toml`` file,
    a dict laid out as a scene file, or a Scene; with ``overrides`` applied (see the module docstring).
    R (``R=...`` or the dict's ``perturbation.R``) is a formula as text or a sympy expression, as
    :func:`pulsemap.derive` takes it.

    >>> sc = scene("fig8-eps0.3", **{"perturbation.eps": 0.2, "output.contacts": [16, 40]})  # doctest: +SKIP

    Raises TypeError for a wrong type, ValueError (pulsemap's SceneError) naming the key for an
    unknown key (with the closest one) or a bad value.
    """
    if isinstance(name_or_path, Scene):
        base = name_or_path
    elif isinstance(name_or_path, (str, Path)):
        base = load_scene(name_or_path)
    elif isinstance(name_or_path, Mapping):
        data = dict(name_or_path)
        if isinstance(data.get("perturbation"), Mapping) and "R" in data["perturbation"]:
            data["perturbation"] = {**data["perturbation"], "R": _formula(data["perturbation"]["R"])}
        base = parse_scene(data, str(name_or_path.get("source") or "<dict>"))
    else:
        raise TypeError(f"name_or_path must be a built-in scene name, a path, a dict or a Scene, "
                        f"got {type(name_or_path).__name__}")
    if not overrides:
        return base
    params = base.perturbation.params
    resolved = [(_resolve(key, params), value) for key, value in overrides.items()]
    return apply_overrides(base, [(key, _formula(value) if key == "perturbation.R" else value)
                                  for key, value in resolved])


def _formula(R: Any) -> Any:
    """R as a scene file holds it: text; a sympy expression (as :func:`pulsemap.derive` takes) is written
    out in the parser's words. Anything else goes on to the scene's own check."""
    if isinstance(R, str) or type(R).__module__.split(".")[0] != "sympy":
        return R
    from pulsemap.symbolic.expression import formula

    return formula(R)


def _resolve(key: str, params: Mapping[str, Any]) -> str:
    """The dotted key an override names; ValueError with the closest key when it names none."""
    if key in KEYS:
        return key
    if key in SHORT:
        return SHORT[key]
    if key.startswith("perturbation.params.") and key.count(".") == 2:
        return key
    if key in params:
        return f"perturbation.params.{key}"
    known = list(KEYS) + list(SHORT) + [f"perturbation.params.{p}" for p in params] + list(params)
    raise SceneError(f"unknown scene key {key!r}{closest(key, known)}: give a key of the scene file, dotted "
                     "(e.g. 'perturbation.eps', 'perturbation.params.mu') or its last part (eps, mu)")
