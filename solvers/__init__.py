"""Numerical side of pulsemap: map iteration, laws, stationary shocks, DNS. numpy + scipy only.

Internal: the public interface is ``pulsemap.derive``, ``scene``, ``run`` and ``scenes``
(:mod:`pulsemap.solvers.api`) and the ``pulsemap`` command; everything else may change.
"""

from pulsemap.symbolic.provenance import __version__  # noqa: F401  (one source for the version)
