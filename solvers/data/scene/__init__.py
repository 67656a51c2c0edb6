"""Scene files: a chain, an excitation, a perturbation and what to report (the format: docs/design.rst, "Scene files").

A scene is TOML data, parsed with :mod:`tomllib` and validated here; nothing in it is ever
executed (R is parsed by :mod:`pulsemap.symbolic.expression`'s whitelisting parser). Every problem is a
:class:`SceneError` with a one-line message naming the file or scene, the problem and the fix.

    name = "damping-eps0.3"
    [chain]                 # optional table
    beads = 140             # N; omit to let the DNS size the chain from the contacts
    exponent = 1.5          # n (default 1.5)
    first_perturbed = 16    # bead where R starts (default 16)
    [excitation]
    velocity = 1.0          # v0 of bead 1
    [perturbation]
    R = "-mu*v"
    eps = 0.3
    [perturbation.params]
    mu = 1.0                # or a list of N per-bead values, {uniform = [0, 1], seed = 7}, "1 + 0.01*i"
    [output]
    contacts = [16, 120]    # first and last contact reported (1-based, inclusive)
    methods = ["map", "longwave", "dns"]
    [model]                 # optional: profile "exact" | "pade", variant "paper" | "corrected" | "1d"
    [dns]                   # optional: rtol (1e-10), atol (1e-12), method ("auto"), engine ("compiled" | "scipy")

Built-in scenes (the paper's figures) live in ``solvers/data/scenes/*.toml``; ``default`` is an alias
of :data:`DEFAULT_SCENE`. ``pulsemap.symbolic.perturbation`` pulls in sympy, so it is imported lazily:
``import pulsemap.solvers.data.scene`` stays light.

The package, by job: :mod:`~pulsemap.solvers.data.scene.schema` (the format: tables, keys,
defaults, :class:`SceneError`), :mod:`~pulsemap.solvers.data.scene.spec` (the frozen :class:`Scene`),
:mod:`~pulsemap.solvers.data.scene.parse` (TOML -> validated Scene, the one place scene input is
checked), :mod:`~pulsemap.solvers.data.scene.files` (built-in and suite scenes by name, reading a
file within :mod:`~pulsemap.solvers.data.scene.toml_bounds`), :mod:`~pulsemap.solvers.data.scene.record`
(the parsed scene kept on disk) and :mod:`~pulsemap.solvers.data.scene.overrides` (``--set`` and
``with_overrides``). This module exposes the entry points.
"""

from pulsemap.solvers.data.scene.files import builtin_scene_path, builtin_scenes, load_scene
from pulsemap.solvers.data.scene.overrides import with_overrides
from pulsemap.solvers.data.scene.parse import check_choice, parse_scene
from pulsemap.solvers.data.scene.schema import (
    ALIASES,
    DEFAULT_EXPONENT,
    DEFAULT_FIRST_PERTURBED,
    DEFAULT_METHODS,
    DEFAULT_SCENE,
    DNS_DEFAULTS,
    DNS_METHODS,
    MAX_BEADS,
    METHODS,
    PROFILES,
    VARIANTS,
    SceneError,
)
from pulsemap.solvers.data.scene.spec import Scene

__all__ = [
    "ALIASES",
    "DEFAULT_EXPONENT",
    "DEFAULT_FIRST_PERTURBED",
    "DEFAULT_METHODS",
    "DEFAULT_SCENE",
    "DNS_DEFAULTS",
    "DNS_METHODS",
    "MAX_BEADS",
    "METHODS",
    "PROFILES",
    "VARIANTS",
    "Scene",
    "SceneError",
    "builtin_scene_path",
    "builtin_scenes",
    "check_choice",
    "load_scene",
    "parse_scene",
    "with_overrides",
]
