"""The public Python API of pulsemap: derive a law, load a scene, run it, list the built-in scenes.

``pulsemap.derive``, ``pulsemap.scene``, ``pulsemap.run`` and ``pulsemap.scenes`` are these
functions; :class:`Derivation` (with its :class:`Balance` models), :class:`Scene` and :class:`Result`
are what they return. Every other module of the package is internal and may change between versions.

Importing this package is cheap: sympy, scipy and numpy are imported when a function first
needs them.
"""

from pulsemap.solvers.api.contact import derive_contact
from pulsemap.solvers.api.derivation import Balance, Derivation, derive
from pulsemap.solvers.api.dressed import dressed
from pulsemap.solvers.api.result import Result
from pulsemap.solvers.api.running import run
from pulsemap.solvers.api.scenes import scene, scenes
from pulsemap.solvers.data.scene import Scene

__all__ = ["Balance", "Derivation", "Result", "Scene", "derive", "derive_contact", "dressed", "run", "scene", "scenes"]
