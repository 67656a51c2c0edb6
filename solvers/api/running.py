"""``pulsemap.run``: a scene's DNS and reduced models side by side (pulsemap.solvers.studies.run)."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.api.checks import run_choices
from pulsemap.solvers.api.result import Result
from pulsemap.solvers.data.scene import Scene

__all__ = ["run"]


def run(
    scene: "Scene | str | Path",
    methods: "Sequence[str] | str | None" = None,
    *,
    profile: str | None = None,
    variant: str | None = None,
    progress: bool = False,
    rank: bool = False,
) -> Result:
    """Run ``scene`` (a :func:`pulsemap.scene`, a built-in name or a path to a scene file).

    ``methods``: any of "dns", "map", "longwave", "energy-map", "energy-law", "momentum-map",
    "momentum-law", "relaxed", "dressed-law" (a list, or one name or comma-separated names);
    default: the scene's own. ``profile`` ("exact" | "pade") and ``variant`` ("paper" |
    "corrected" | "1d") override the scene's. With the DNS among the methods, the models start
    from its peak at the last unperturbed contact and their errors against it (percent over the
    live range) are in :attr:`Result.errors`. ``progress``: report the DNS's progress on stderr.
    ``rank``: also rank every model against the DNS (:attr:`Result.ranking`); the best joins the
    peaks and errors under its ranking name (e.g. "relaxed", "map/1d").
    """
    from pulsemap.solvers.api.scenes import scene as load
    from pulsemap.solvers.studies.run import run_scene

    if not isinstance(scene, Scene):
        if not isinstance(scene, (str, Path)):
            raise TypeError(f"scene must be a Scene (pulsemap.scene(...)), a built-in name or a path, "
                            f"got {type(scene).__name__}")
        scene = load(scene)
    if isinstance(methods, str):
        methods = [m.strip() for m in methods.split(",")]
    elif methods is not None:
        if not isinstance(methods, (list, tuple)) or not all(isinstance(m, str) for m in methods):
            raise TypeError(f"methods must be a list of method names (e.g. ['dns', 'map']), got {methods!r}")
        if not methods:
            raise PulsemapError("methods is empty: give at least one of dns, map, longwave, ...")
    for name, value in (("profile", profile), ("variant", variant)):
        if value is not None and not isinstance(value, str):
            raise TypeError(f"{name} must be a string, got {type(value).__name__} {value!r}")
    for name, flag in (("progress", progress), ("rank", rank)):
        if not isinstance(flag, bool):
            raise TypeError(f"{name} must be True or False, got {flag!r}")
    if rank and "dns" not in [m.strip() for m in (methods or scene.methods)]:
        raise PulsemapError("rank=True ranks every model against the DNS: add 'dns' to the methods")
    methods, profile, variant, _ = run_choices(scene, methods, profile, variant)
    out = run_scene(scene, methods=methods, profile=profile, variant=variant, progress=progress)
    if rank:
        from pulsemap.solvers.studies.ranking import add_ranking

        add_ranking(scene, out)
    return Result.from_run(out)
