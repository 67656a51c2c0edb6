"""The Result of :func:`pulsemap.run`: peaks per contact as numpy arrays, errors against the DNS,
timings, and what produced each number; converts to a dict, a pandas DataFrame or a figure."""

from __future__ import annotations

import copy
import html
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Mapping

if TYPE_CHECKING:  # pragma: no cover - numpy, pandas and matplotlib load when a result is made or shown
    import numpy as np
    import pandas
    from matplotlib.figure import Figure
    from numpy.typing import NDArray

__all__ = ["Result"]

NOTEBOOK_HINT = 'pip install "pulsemap[notebook]"'


@dataclass(frozen=True)
class Result:
    """One run of a scene (:func:`pulsemap.run`).

    Peaks are the leading-edge maxima of the contact strains delta_i = x_i - x_(i+1) at the
    contacts in :attr:`contacts`; a contact without a value (the model stopped, the DNS lost the
    primary pulse) holds NaN.
    """

    scene: str
    """Name of the scene that was run."""
    contacts: NDArray[np.int_]
    """Contacts i (numpy int array), first..last of the scene."""
    peaks: Mapping[str, NDArray[np.float64]]
    """Method -> peaks per contact (numpy float arrays), for every method that was computed."""
    errors: Mapping[str, Mapping[str, Any]]
    """Model -> its error against the DNS, the one definition every output uses: ``rms_pct`` and
    ``max_pct`` (percent) over ``live_range`` (contacts first_perturbed up to the last whose DNS
    peak is >= 2 % of the seed peak; a live contact without a model value counts 100 %),
    ``compared``, ``missing`` and ``unit`` ("percent")."""
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

    def to_dataframe(self) -> pandas.DataFrame:
        """A pandas DataFrame, one row per contact (index ``contact``), one column per method
        (NaN where a method has no value) and ``dns_alive`` when the DNS ran. Needs pandas."""
        try:
            import pandas as pd
        except ImportError:
            raise ImportError(f"Result.to_dataframe() needs pandas: {NOTEBOOK_HINT}") from None
        columns: dict[str, Any] = dict(self.peaks)
        alive = (self.data.get("dns") or {}).get("alive")
        if alive is not None:
            columns["dns_alive"] = list(alive)
        frame = pd.DataFrame(columns, index=pd.Index(self.contacts, name="contact"))
        frame.attrs["scene"] = self.scene
        return frame

    def plot(self, path: str | None = None, *, log_y: bool = False) -> Figure:
        """The peaks against the contact index in the paper's style (DNS +, map dots, law a line);
        saved to ``path`` when given. Returns the matplotlib Figure. Needs matplotlib."""
        from pulsemap.solvers.data.plotting import figures, peaks_figure, save

        try:
            plt = figures(ImportError)
        except ImportError:
            raise ImportError(f"Result.plot() needs matplotlib: {NOTEBOOK_HINT}") from None
        fig = peaks_figure(self.data, plt, log_y)
        if path is not None:
            save(fig, path)
        return fig

    def __str__(self) -> str:
        from pulsemap.solvers.studies.run.report import to_text

        return to_text(self.data)

    @property
    def ranking(self) -> list[dict]:
        """Every model against the DNS, least RMS first (``pulsemap.run(..., rank=True)``; else [])."""
        return copy.deepcopy(self.data.get("ranking") or [])

    def _repr_html_(self) -> str:
        """A compact table for Jupyter: per method its error, time and what produced it; then provenance."""
        sc = self.provenance["scene"]
        ch = self.provenance["choices"]
        e = html.escape
        head = (f"<b>{e(self.scene)}</b>: R = <code>{e(str(sc['perturbation']['R']))}</code>, "
                f"eps = {sc['perturbation']['eps']:g}, v0 = {sc['excitation']['velocity']:g}, contacts "
                f"{int(self.contacts[0])}..{int(self.contacts[-1])}; profile {e(ch['profile'])}, "
                f"map variant {e(ch['variant'])}")
        span = next((err["live_range"] for err in self.errors.values() if err.get("live_range")), None)
        where = f" over contacts {span[0]}..{span[1]}" if span else ""
        best = (self.data.get("best") or {}).get("column")
        rows = [f"<tr><th>method</th><th>RMS error %{where}</th><th>max error %</th><th>time [s]</th>"
                "<th>produced by</th></tr>"]
        for name in self.methods:
            err = self.errors.get(name, {})
            how = self.produced_by.get(name, {})
            if name == "dns":
                what = f"{how.get('method', '')} rtol {how.get('rtol', '')} atol {how.get('atol', '')}"
            else:
                what = ", ".join([str(how.get("model", ""))] + [f"{k} {how[k]}" for k in ("profile", "variant")
                                                                if k in how])
            label = f"{name} (best)" if name == best else name
            rows.append("<tr>" + "".join(f"<td>{e(str(c))}</td>" for c in (
                label, _fmt(err.get("rms_pct")), _fmt(err.get("max_pct")), _fmt(self.timings.get(name), ".3g"),
                what)) + "</tr>")
        versions = ", ".join(f"{k} {v}" for k, v in self.provenance.items()
                             if isinstance(v, str) and k != "pulsemap_version")  # "pulsemap" is there too
        warn = "".join(f"<li>{e(w)}</li>" for w in self.warnings)
        return (f"<div>{head}<table>{''.join(rows)}</table><small>{e(versions)}</small>"
                + (f"<ul>{warn}</ul>" if warn else "") + "</div>")

    def __repr__(self) -> str:
        errs = ", ".join(f"{k} {_fmt(v.get('rms_pct'))}" for k, v in self.errors.items())
        R = self.provenance.get("scene", {}).get("perturbation", {}).get("R")
        return (f"Result(scene={self.scene!r}, R={R!r}, methods={list(self.methods)}, contacts="
                f"{int(self.contacts[0])}..{int(self.contacts[-1])}" + (f", RMS error % vs DNS: {errs}" if errs else "")
                + ")")


def _fmt(x: float | None, spec: str = ".3g") -> str:
    return "" if x is None else format(x, spec)
