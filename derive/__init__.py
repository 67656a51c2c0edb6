"""Symbolic side of pulsemap: profile, universal integrals, expansion of R, map, laws.

Never imports scipy (see DESIGN.md, layering).
"""
