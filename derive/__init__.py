"""Symbolic side of pulsemap: profile, universal integrals, expansion of R, map, laws.

Never imports scipy (docs/design.rst, "Layers").
"""

from .provenance import __version__  # noqa: F401  (the package version, one source for both packages)
