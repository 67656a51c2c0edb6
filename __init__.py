"""pulsemap: primary pulses in uncompressed granular chains with on-site perturbations.

The public API (everything else in the package is internal and may change):

* :func:`pulsemap.derive` ``(R, eps=0.1, n=1.5, profile=..., variant=..., **params)`` -> a
  :class:`Derivation`: the amplitude map (Eq. 23), the long-wave law (Eq. 30) and Eq. 41;
* :func:`pulsemap.derive_contact` ``(P, eps=0.1, n=1.5, mass=1, **params)`` -> the first-order energy law of a
  contact-law term P(d, w) (dashpot, Kuwabara-Kono, elastic corrections) with its constants;
* :func:`pulsemap.dressed` ``(R, eps=0.1, n=1.5, A0=None, i0=0, **params)`` -> the dressed
  (second-order) law of the energy balance, k1 derived, k2/k1, onset lag and cross terms calibrated;
* :func:`pulsemap.scene` ``(name_or_path, **overrides)`` -> a validated :class:`Scene`;
* :func:`pulsemap.run` ``(scene, methods=...)`` -> a :class:`Result` (peaks as numpy arrays,
  errors against the DNS, timings, provenance);
* :func:`pulsemap.scenes` ``()`` -> the names of the built-in scenes;
* :class:`pulsemap.PulsemapError`: the base of every error pulsemap raises for what it was asked (a
  ``ValueError``); any other exception is a bug.

``import pulsemap`` is cheap: sympy, scipy and numpy load when a function first needs them.
The symbolic layer (the ``derive/`` folder) installs as :mod:`pulsemap.symbolic`, so that
``pulsemap.derive`` is a plain function.
"""

from pulsemap.solvers.api import Balance, Derivation, Result, Scene, derive, derive_contact, dressed, run, scene, scenes
from pulsemap.symbolic.errors import PulsemapError
from pulsemap.symbolic.provenance import __version__

__all__ = ["Balance", "Derivation", "PulsemapError", "Result", "Scene", "__version__", "derive", "derive_contact", "dressed",
           "run", "scene", "scenes"]
