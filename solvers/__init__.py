"""Numerical side of pulsemap: map iteration, laws, stationary shocks, DNS. numpy + scipy only."""

__version__ = "0.1.0"
