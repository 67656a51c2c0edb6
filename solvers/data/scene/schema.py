"""The scene file format: tables, keys, defaults and choices, and SceneError.

What a scene file may hold (see :mod:`pulsemap.solvers.data.scene` for an example); the checks
are :mod:`.parse`. No sympy here.
"""

from __future__ import annotations

from typing import Any, Mapping

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.chain.methods import MAX_BEADS, selectable  # noqa: F401  (MAX_BEADS: the scene files' limit)


METHODS = ("map", "longwave", "energy-map", "energy-law", "momentum-map", "momentum-law", "relaxed", "dressed-law",
           "dns")
"""The ways a scene can be computed, in canonical order (balance models: derive/balance.py; relaxed:
solvers/models/relaxed.py; dressed-law: solvers/studies/dressed.py)."""
DEFAULT_METHODS = ("map", "longwave", "dns")
"""What a scene without [output] methods computes."""
PROFILES = ("exact", "pade")
VARIANTS = ("paper", "corrected", "1d")
DNS_METHODS = selectable()  # chain/methods.py's table
DNS_ENGINES = ("compiled", "scipy")  # [dns] engine, optional (absent: "compiled" where it applies)
DNS_MODES = ("window", "full")  # [dns] mode, optional (absent: "window", the moving window of chain/window.py)
DNS_DEFAULTS: Mapping[str, Any] = {"rtol": 1e-10, "atol": 1e-12, "method": "auto"}
DEFAULT_SCENE = "fig8-eps0.3"
"""What ``load_scene("default")`` returns: linear damping, cheap, the quick start's main job."""
ALIASES = {"default": DEFAULT_SCENE}
DEFAULT_FIRST_PERTURBED = 16
DEFAULT_EXPONENT = 1.5

# Keys allowed in each table; None marks a sub-table.
SCHEMA: dict[str, tuple[str, ...]] = {
    "": ("name", "source", "chain", "excitation", "perturbation", "contact", "masses", "output", "model", "dns"),
    "chain": ("beads", "exponent", "first_perturbed"),
    "excitation": ("velocity",),
    "perturbation": ("R", "eps", "params"),
    "contact": ("P", "eps", "first_perturbed", "params"),
    "masses": ("m", "first_perturbed", "params"),
    "output": ("contacts", "methods"),
    "model": ("profile", "variant"),
    "dns": ("rtol", "atol", "method", "engine", "mode"),
}
TABLES = ("chain", "excitation", "perturbation", "contact", "masses", "output", "model", "dns")
REQUIRED_TABLES = ("excitation", "perturbation", "output")
"""[perturbation] may be left out when [contact] or [masses] is given (R = 0 then)."""
PERTURBATION_TABLES = ("perturbation", "contact", "masses")
REQUIRED_KEYS = {"excitation": ("velocity",), "perturbation": ("R", "eps"), "output": ("contacts",),
                 "contact": ("P", "eps"), "masses": ("m",)}
EXAMPLES = {
    "excitation.velocity": "velocity = 1.0",
    "perturbation.R": 'R = "-mu*v"',
    "perturbation.eps": "eps = 0.1",
    "output.contacts": "contacts = [16, 120]",
    "contact.P": 'P = "gamma*w"',
    "contact.eps": "eps = 0.02",
    "masses.m": 'm = "1 + taper*(i - 16)"',
}


#: Fields of a Scene (overrides.with_overrides) by their dotted key in the scene file.
FIELD_KEYS = {"beads": "chain.beads", "exponent": "chain.exponent", "first_perturbed": "chain.first_perturbed",
              "velocity": "excitation.velocity", "contacts": "output.contacts", "methods": "output.methods",
              "profile": "model.profile", "variant": "model.variant", "R": "perturbation.R",
              "eps": "perturbation.eps", "params": "perturbation.params", "name": "name"}
#: Tables a Scene holds whole (None: absent), by field: the contact law and the masses.
TABLE_FIELDS = {"contact": "contact", "masses": "masses"}


class SceneError(PulsemapError):
    """A scene file or scene value was rejected; the one-line message says why and what to do."""
