"""pulsemap: primary pulses in uncompressed granular chains with on-site perturbations.

The public API (everything else in the package is internal and may change):

* :func:`pulsemap.derive` ``(R, eps=0.1, n=1.5, profile=..., variant=..., **params)`` -> a
  :class:`Derivation`: the amplitude map (Eq. 23), the long-wave law (Eq. 30) and Eq. 41;
* :func:`pulsemap.dressed` ``(R, eps=0.1, n=1.5, A0=None, i0=0, **params)`` -> the dressed
  (second-order) law of the energy balance, k1 derived, k2/k1, onset lag and cross terms calibrated;
* :func:`pulsemap.scene` ``(name_or_path, **overrides)`` -> a validated Scene;
* :func:`pulsemap.run` ``(scene, methods=...)`` -> a :class:`Result` (peaks as numpy arrays,
  errors against the DNS, timings, provenance);
* :func:`pulsemap.scenes` ``()`` -> the names of the built-in scenes.

``import pulsemap`` is cheap: sympy, scipy and numpy load when a function first needs them.
``pulsemap.derive`` is also the subpackage of the symbolic layer (``pulsemap.derive.profile``, ...);
calling it calls :func:`pulsemap.solvers.api.derive`.
"""

from __future__ import annotations

import types
from typing import Any

import pulsemap.derive as _derive_package
from pulsemap.derive.provenance import __version__
from pulsemap.solvers.api import Derivation, Result, dressed, run, scene, scenes
from pulsemap.solvers.api.derivation import derive as _derive

__all__ = ["Derivation", "Result", "__version__", "derive", "dressed", "run", "scene", "scenes"]


class _CallableSubpackage(types.ModuleType):
    """``pulsemap.derive`` is both the subpackage and the function (the import system binds the
    subpackage to this name, so the function lives on the subpackage's call)."""

    def __call__(self, R: str, **kwargs: Any) -> Derivation:
        return _derive(R, **kwargs)


_derive_package.__class__ = _CallableSubpackage
_derive_package.__wrapped__ = _derive  # inspect.signature(pulsemap.derive) is the function's
derive = _derive_package
