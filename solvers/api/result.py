"""The Result of :func:`pulsemap.run`: peaks per contact as numpy arrays, errors against the DNS,
timings, and what produced each number; converts to a dict, a pandas DataFrame or a figure."""

from __future__ import annotations

import copy
import html
from dataclasses import dataclass, field
from typing import Any, Mapping

__all__ = ["Result"]

PLOT_HINT = 'pip install "pulsemap[plot]"'


@dataclass(frozen=True)
class Result:
    """One run of a scene (:func:`pulsemap.run`).

    Peaks are the leading-edge maxima of the contact strains delta_i = x_i - x_(i+1) at the
    contacts in :attr:`contacts`; a contact without a value (the model stopped, the DNS lost the
    primary pulse) holds NaN.
    """

    scene: str
    """Name of the scene that was run."""
    contacts: Any
    """Contacts i (numpy int array), first..last of the scene."""
    peaks: Mapping[str, Any]
    """Method -> peaks per contact (numpy float arrays), for every method that was computed."""
    errors: Mapping[str, Mapping[str, Any]]
    """Model -> errors against the live DNS peaks: max_rel, rms_rel, compared, missing, and
    max_rel_strong (only where the DNS peak is at least 10 % of the seed peak)."""
    timings: Mapping[str, float]
    """Seconds per step (derive_map, dns, map, longwave, ...)."""
    produced_by: Mapping[str, Mapping[str, Any]]
    """Method -> what produced its numbers: profile and variant of a model, the seed it started
    from; integrator, tolerances and chain length of the DNS."""
    provenance: Mapping[str, Any]
    """Package and library versions, the scene as run (every default filled in) and the choices."""
    warnings: tuple[str, ...]
    """Where a model left its assumptions or the DNS lost the pulse."""
    data: dict = field(repr=False, compare=False, default_factory=dict)
    """The run as JSON-serialisable data (the document of ``pulsemap run --json``)."""

    @classmethod
    def from_run(cls, out: dict) -> "Result":
        """Wrap the data :func:`pulsemap.solvers.studies.run.run_scene` returns."""
        import numpy as np

        contacts = np.asarray(out["contacts"], dtype=int)
        peaks = {name: np.array([np.nan if v is None else v for v in values], dtype=float)
                 for name, values in out["peaks"].items() if values is not None}
        choices = out["choices"]
        produced: dict[str, dict] = {}
        for name in peaks:
            info = dict(out.get(name) or {})
            if name != "dns":
                info.setdefault("profile", choices["profile"])
                if name == "map":
                    info.setdefault("variant", choices["variant"])
                if "seed" in out:
                    info["seed"] = dict(out["seed"])
            produced[name] = info
        provenance = {"pulsemap_version": out["pulsemap_version"], **out["provenance"],
                      "scene": out["scene"], "choices": choices}
        return cls(
            scene=out["scene"]["name"], contacts=contacts, peaks=peaks,
            errors={k: dict(v) for k, v in out["errors"].items()}, timings=dict(out["timings_s"]),
            produced_by=produced, provenance=provenance, warnings=tuple(out["warnings"]), data=out,
        )

    @property
    def methods(self) -> tuple[str, ...]:
        """The methods that produced peaks, in canonical order (dns first)."""
        return tuple(self.peaks)

    def to_dict(self) -> dict:
        """A deep copy of the JSON-serialisable data (``pulsemap run --json``)."""
        return copy.deepcopy(self.data)

    def to_dataframe(self):
        """A pandas DataFrame, one row per contact (index ``contact``), one column per method
        (NaN where a method has no value) and ``dns_alive`` when the DNS ran. Needs pandas."""
        try:
            import pandas as pd
        except ImportError:
            raise ImportError("Result.to_dataframe() needs pandas: pip install pandas") from None
        columns: dict[str, Any] = dict(self.peaks)
        alive = (self.data.get("dns") or {}).get("alive")
        if alive is not None:
            columns["dns_alive"] = list(alive)
        frame = pd.DataFrame(columns, index=pd.Index(self.contacts, name="contact"))
        frame.attrs["scene"] = self.scene
        return frame

    def plot(self, path: str | None = None, *, log_y: bool = False):
        """The peaks against the contact index in the paper's style (DNS +, map dots, law a line);
        saved to ``path`` when given. Returns the matplotlib Figure. Needs matplotlib."""
        try:
            from matplotlib.figure import Figure
        except ImportError:
            raise ImportError(f"Result.plot() needs matplotlib: {PLOT_HINT}") from None
        from pulsemap.solvers.data.plotting import peaks_figure

        class _Figures:  # peaks_figure's plt.subplots, without pyplot (keeps the caller's backend)
            @staticmethod
            def subplots(figsize):
                fig = Figure(figsize=figsize)
                return fig, fig.subplots()

        fig = peaks_figure(self.data, _Figures, log_y)
        if path is not None:
            fig.savefig(path, dpi=120)
        return fig

    def __str__(self) -> str:
        from pulsemap.solvers.studies.run_report import to_text

        return to_text(self.data)

    def _repr_html_(self) -> str:
        sc = self.provenance["scene"]
        ch = self.provenance["choices"]
        e = html.escape
        head = (f"<b>{e(self.scene)}</b>: R = <code>{e(str(sc['perturbation']['R']))}</code>, "
                f"eps = {sc['perturbation']['eps']:g}, v0 = {sc['excitation']['velocity']:g}, contacts "
                f"{int(self.contacts[0])}..{int(self.contacts[-1])}; profile {e(ch['profile'])}, "
                f"map variant {e(ch['variant'])}")
        rows = ["<tr><th>method</th><th>max rel error vs DNS</th><th>rms rel error</th>"
                "<th>contacts compared</th><th>time [s]</th><th>produced by</th></tr>"]
        for name in self.methods:
            err = self.errors.get(name, {})
            how = self.produced_by.get(name, {})
            if name == "dns":
                what = f"{how.get('method', '')} rtol {how.get('rtol', '')} atol {how.get('atol', '')}"
            else:
                what = ", ".join(f"{k} {how[k]}" for k in ("profile", "variant") if k in how)
            rows.append("<tr>" + "".join(f"<td>{e(str(c))}</td>" for c in (
                name, _fmt(err.get("max_rel")), _fmt(err.get("rms_rel")), err.get("compared", ""),
                _fmt(self.timings.get(name), ".3g"), what)) + "</tr>")
        warn = "".join(f"<li>{e(w)}</li>" for w in self.warnings)
        return (f"<div>{head}<table>{''.join(rows)}</table>"
                + (f"<ul>{warn}</ul>" if warn else "") + "</div>")

    def __repr__(self) -> str:
        errs = ", ".join(f"{k} {_fmt(v.get('max_rel'))}" for k, v in self.errors.items())
        return (f"Result(scene={self.scene!r}, methods={list(self.methods)}, contacts="
                f"{int(self.contacts[0])}..{int(self.contacts[-1])}" + (f", max rel error vs DNS: {errs}" if errs else "")
                + ")")


def _fmt(x: float | None, spec: str = ".3g") -> str:
    return "" if x is None else format(x, spec)
