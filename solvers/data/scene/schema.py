"""The scene file format: tables, keys, defaults and choices, and SceneError.

What a scene file may hold (see :mod:`pulsemap.solvers.data.scene` for an example); the checks
are :mod:`.parse`. No sympy here.
"""

from __future__ import annotations

from typing import Any, Mapping

from pulsemap.symbolic.errors import PulsemapError


METHODS = ("map", "longwave", "energy-map", "energy-law", "momentum-map", "momentum-law", "relaxed", "dressed-law",
           "dns")
"""The ways a scene can be computed, in canonical order (balance models: derive/balance.py; relaxed:
solvers/models/relaxed.py; dressed-law: solvers/studies/dressed.py)."""
DEFAULT_METHODS = ("map", "longwave", "dns")
"""What a scene without [output] methods computes."""
PROFILES = ("exact", "pade")
VARIANTS = ("paper", "corrected", "1d")
DNS_METHODS = ("auto", "DOP853", "RK45", "Radau", "BDF", "LSODA")
DNS_ENGINES = ("compiled", "scipy")  # [dns] engine, optional (absent: "compiled" where it applies)
DNS_MODES = ("window", "full")  # [dns] mode, optional (absent: "window", the moving window of chain/window.py)
DNS_DEFAULTS: Mapping[str, Any] = {"rtol": 1e-10, "atol": 1e-12, "method": "auto"}
DEFAULT_SCENE = "fig8-eps0.3"
"""What ``load_scene("default")`` returns: linear damping, cheap, the quick start's main job."""
ALIASES = {"default": DEFAULT_SCENE}
DEFAULT_FIRST_PERTURBED = 16
DEFAULT_EXPONENT = 1.5
MAX_BEADS = 1_000_000

# Keys allowed in each table; None marks a sub-table.
SCHEMA: dict[str, tuple[str, ...]] = {
    "": ("name", "source", "chain", "excitation", "perturbation", "output", "model", "dns"),
    "chain": ("beads", "exponent", "first_perturbed"),
    "excitation": ("velocity",),
    "perturbation": ("R", "eps", "params"),
    "output": ("contacts", "methods"),
    "model": ("profile", "variant"),
    "dns": ("rtol", "atol", "method", "engine", "mode"),
}
TABLES = ("chain", "excitation", "perturbation", "output", "model", "dns")
REQUIRED_TABLES = ("excitation", "perturbation", "output")
REQUIRED_KEYS = {"excitation": ("velocity",), "perturbation": ("R", "eps"), "output": ("contacts",)}
EXAMPLES = {
    "excitation.velocity": "velocity = 1.0",
    "perturbation.R": 'R = "-mu*v"',
    "perturbation.eps": "eps = 0.1",
    "output.contacts": "contacts = [16, 120]",
}


#: Fields of a Scene (overrides.with_overrides) by their dotted key in the scene file.
FIELD_KEYS = {"beads": "chain.beads", "exponent": "chain.exponent", "first_perturbed": "chain.first_perturbed",
              "velocity": "excitation.velocity", "contacts": "output.contacts", "methods": "output.methods",
              "profile": "model.profile", "variant": "model.variant", "R": "perturbation.R",
              "eps": "perturbation.eps", "params": "perturbation.params", "name": "name"}


class SceneError(PulsemapError):
    """A scene file or scene value was rejected; the one-line message says why and what to do."""
