"""Numerical side of pulsemap: map iteration, laws, stationary shocks, DNS. numpy + scipy only."""

from pulsemap.derive.provenance import __version__  # noqa: F401  (one source for the version)
