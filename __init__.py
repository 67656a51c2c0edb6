"""pulsemap: primary pulses in uncompressed granular chains with on-site perturbations."""

from pulsemap.derive.provenance import __version__  # noqa: F401
