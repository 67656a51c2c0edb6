"""Symbolic side of pulsemap: profile, universal integrals, expansion of R, map, laws.

Never imports scipy (see DESIGN.md, layering).
"""

from .provenance import __version__  # noqa: F401  (the package version, one source for both packages)
