"""Matplotlib for the ``--plot`` options: optional, headless (Agg backend), one clear error when missing."""

from __future__ import annotations

NEEDS_MATPLOTLIB = "--plot needs matplotlib: pip install 'pulsemap[plot]'"


def pyplot(error: type[ValueError] = ValueError):
    """``matplotlib.pyplot`` on the Agg backend; raises ``error`` naming the fix when matplotlib is missing."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise error(NEEDS_MATPLOTLIB) from None
    return plt
