"""Matplotlib for the figures: optional, one clear error when missing, no pyplot.

Figures are built as ``matplotlib.figure.Figure`` objects, never through pyplot: nothing changes
the caller's backend, nothing is closed behind a notebook's back, and a figure returned to
Jupyter shows itself (it has ``_repr_png_``) without ``%matplotlib inline``.
Also the figure of ``pulsemap run``: leading-edge peaks per contact for the DNS and every model,
the contact where the DNS lost the pulse marked, a legend entry for every line, linear or log y.
"""

from __future__ import annotations

import functools
import importlib.util

#: The one hint every --plot gives when matplotlib is missing.
INSTALL_HINT = 'pip install "pulsemap[plot]"'
NEEDS_MATPLOTLIB = f"--plot needs matplotlib: {INSTALL_HINT}"


@functools.lru_cache(maxsize=None)
def _figure_class():
    """A matplotlib Figure that renders itself as PNG in Jupyter (no pyplot, no backend)."""
    import io

    from matplotlib.figure import Figure

    class InlineFigure(Figure):
        def _repr_png_(self) -> bytes:
            buf = io.BytesIO()
            self.savefig(buf, format="png", dpi=100, bbox_inches="tight")
            return buf.getvalue()

    return InlineFigure


class Figures:
    """``subplots`` as pyplot has it, making backend-free figures (see the module docstring)."""

    @staticmethod
    def subplots(nrows: int = 1, ncols: int = 1, *, figsize=None, **kwargs):
        fig = _figure_class()(figsize=figsize)
        return fig, fig.subplots(nrows, ncols, **kwargs)

    @staticmethod
    def close(fig) -> None:
        """Nothing to release: the figure is no pyplot figure."""


def figures(error: type[Exception] = ValueError) -> Figures:
    """The figure maker; raises ``error`` naming the fix when matplotlib is missing."""
    try:
        import matplotlib.figure  # noqa: F401 (checked on every call: the class below is cached)

        _figure_class()
    except ImportError:
        raise error(NEEDS_MATPLOTLIB) from None
    return Figures()


def require_matplotlib(error: type[ValueError] = ValueError) -> None:
    """Fail before a long run, not after it: ``error`` with the install hint when matplotlib is missing
    (without importing it: a run that needs it imports it when it plots)."""
    try:
        found = importlib.util.find_spec("matplotlib") is not None
    except (ImportError, ValueError):  # a broken or blocked module entry
        found = False
    if not found:
        raise error(NEEDS_MATPLOTLIB)


#: Line styles of the models in run's figure (the paper's: DNS +, map dots, long-wave law a line).
_STYLES = {"dns": ("k+", {}), "map": ("r.", {}), "longwave": ("b-", {"lw": 1})}


def _series(contacts: list, values: list | None) -> tuple[list, list]:
    if values is None:
        return [], []
    pts = [(c, v) for c, v in zip(contacts, values) if v is not None and v > 0]
    return [p[0] for p in pts], [p[1] for p in pts]


def peaks_figure(result: dict, plt, log_y: bool = False):
    """Figure of a run result (solvers/studies/run/): one line per method with a legend entry,
    the DNS's last live contact marked with the reason it stopped; ``log_y`` for decaying peaks."""
    contacts = result["contacts"]
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    ch = result.get("choices", {})
    titles = {"dns": "DNS", "map": f"map ({ch.get('variant', '?')}, {ch.get('profile', '?')})",
              "longwave": "long-wave law"}
    for name, values in result["peaks"].items():
        x, y = _series(contacts, values)
        if not x:
            continue
        fmt, kw = _STYLES.get(name, ("--" if name.endswith("law") else ":", {"lw": 1}))
        best = name == (result.get("best") or {}).get("column")
        ax.plot(x, y, fmt, label=titles.get(name, name) + (" (best of the ranking)" if best else ""), **kw)
    dns = result.get("dns") or {}
    alive = dns.get("alive")
    if alive and not all(alive) and any(alive):
        k = max(j for j, a in enumerate(alive) if a)
        reason = str(dns.get("stop_reason", "")).split(" (")[0]
        ax.plot([contacts[k]], [result["peaks"]["dns"][k]], "x", color="tab:red", ms=10, mew=2,
                label=f"DNS pulse lost after contact {contacts[k]}: {reason}"[:90])
    ax.set_xlabel("contact i")
    ax.set_ylabel("peak: leading-edge max of delta_i = x_i - x_(i+1)")
    if log_y:
        ax.set_yscale("log")
    ax.set_title(result["scene"]["name"])
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def save(fig, path: str) -> None:
    """Write ``fig`` to ``path`` atomically (its format from the suffix, PNG without one): a failed
    write leaves an earlier file whole and no temporary behind."""
    import io
    from pathlib import Path

    from pulsemap.symbolic.files import write_atomic

    buf = io.BytesIO()
    fig.savefig(buf, format=Path(path).suffix[1:].lower() or "png", dpi=120)
    write_atomic(path, buf.getvalue())
