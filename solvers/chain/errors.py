"""The DNS's error for input no run can use (no numba, no scipy: every chain module imports it)."""

from __future__ import annotations

from pulsemap.symbolic.errors import PulsemapError


class DNSInputError(PulsemapError):
    """A value given to the DNS (an option object: Chain, Integrator, StopRules, Snapshots, WindowSpec; a run's
    arguments) that no run can use; the one-line message names the field and what it takes."""
