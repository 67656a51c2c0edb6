"""The DNS side of a bifurcation study: probes on a plain chain, their outcome (settles, decays,
undecided), the bracket of the threshold and its bisection (paper Sec. 4.4)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Sequence

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.data.scene import with_overrides
from pulsemap.solvers.studies.points import dns_task
from pulsemap.solvers.studies.sweep import run_sweep

__all__ = ["BifurcationError", "Outcome", "ProbeRunner", "bisect", "bracket", "check_param", "classify", "entry_peak", "probe"]


class BifurcationError(PulsemapError):
    """A bifurcation sweep that cannot be run as asked."""


# ----------------------------------------------------------------------------- classification


@dataclass(frozen=True)
class Outcome:
    """What the primary pulse did in one DNS run."""

    kind: str  # "settles" | "decays" | "undecided"
    amplitude: float | None  # stationary peak when it settles
    final_peak: float | None  # last live peak
    alive_to: int | None  # last contact with a live primary pulse
    drift: float | None  # relative change of the peak over the last settle_window contacts


def classify(result: dict, settle_window: int = 50, settle_tol: float = 1e-3) -> Outcome:
    """Settles, decays or undecided, from a DNS task's peaks (see the module docstring)."""
    contacts, peaks = result["contacts"], result["peaks"]
    last = contacts[-1]
    alive_to = result.get("alive_to")
    live = [p for p in peaks if p is not None]
    final = live[-1] if live else None
    if alive_to is None or alive_to < last:
        kind = "decays" if "died" in result.get("stop_reason", "") else "undecided"
        return Outcome(kind, None, final, alive_to, None)
    j = len(peaks) - 1 - settle_window
    ref = peaks[j] if j >= 0 else None
    if ref is None:
        return Outcome("undecided", None, final, alive_to, None)
    drift = (final - ref) / final
    if abs(drift) <= settle_tol:
        return Outcome("settles", final, final, alive_to, drift)
    return Outcome("undecided", None, final, alive_to, drift)


def entry_peak(result: dict, first_perturbed: int) -> float | None:
    """The DNS peak at contact first_perturbed - 1 (what seeds the map, Eq. 32)."""
    c = first_perturbed - 1
    return result["peaks"][result["contacts"].index(c)] if c in result["contacts"] else None


def check_param(scene, name: str) -> None:
    """``name`` must be a scalar parameter of the scene's R."""
    pert = scene.perturbation
    if name not in pert.used_parameters:
        used = ", ".join(pert.used_parameters) or "none"
        raise BifurcationError(f"'{name}' is not a parameter of R = {pert.text} (parameters: {used}): choose one with --param")
    if name in pert.site_dependent:
        raise BifurcationError(f"parameter '{name}' varies along the chain: the bifurcation needs a scalar parameter")
    if pert.site_dependent:
        raise BifurcationError(f"parameter '{pert.site_dependent[0]}' varies along the chain: Eq. 41 needs a uniform "
                               "chain, give it a single value")


def base_chain(scene, last: int, rtol: float, window: "int | str | None" = "auto") -> dict:
    """The plain chain of the DNS probes (contacts first_perturbed - 1 .. last; bifurcation() checks last)."""
    from pulsemap.solvers.studies.points import plain_chain

    sc = with_overrides(scene, contacts=(scene.first_perturbed, int(last)), beads=None)
    return plain_chain(sc, window=window, rtol=rtol, study="bifurcation")


def probe(chain: dict, name: str, value: float, v0: float, last: int) -> dict:
    """The plain point of one DNS probe: parameter ``name`` = value, impulse v0, ``last`` contacts."""
    from pulsemap.solvers.chain.dns import chain_length_for

    p = {**chain, "params": {**chain["params"], name: float(value)}, "velocity": float(v0),
         "contacts": [chain["contacts"][0], int(last)], "beads": chain_length_for(int(last))}
    return p


def _summary(rec: dict, name: str, first_perturbed: int, settle_window: int, settle_tol: float) -> dict:
    prm = rec["params"]
    row = {"value": prm["params"][name], "v0": prm["velocity"], "last": prm["contacts"][1], "key": rec["key"]}
    if rec["status"] != "ok":
        row.update({"outcome": "failed", "error": rec.get("error")})
        return row
    res = rec["result"]
    out = classify(res, settle_window, settle_tol)
    row.update({"outcome": out.kind, "amplitude": out.amplitude, "final_peak": out.final_peak,
                "alive_to": out.alive_to, "drift": out.drift, "entry_peak": entry_peak(res, first_perturbed),
                "stop_reason": res["stop_reason"], "elapsed_s": rec.get("elapsed_s")})
    return row


def bracket(rows: Sequence[dict]) -> tuple[float | None, float | None]:
    """(largest value that decays below the smallest that settles, smallest that settles)."""
    settles = sorted(r["value"] for r in rows if r["outcome"] == "settles")
    if not settles:
        return (max((r["value"] for r in rows if r["outcome"] == "decays"), default=None), None)
    hi = settles[0]
    below = [r["value"] for r in rows if r["outcome"] == "decays" and r["value"] < hi]
    return (max(below) if below else None, hi)


@dataclass
class ProbeRunner:
    """Runs batches of DNS probes of one parameter on one plain chain (pulsemap.solvers.studies.sweep.run_sweep)
    and summarises each; ``sweeps`` collects every batch's sweep summary."""

    chain: dict
    name: str
    first_perturbed: int
    settle_window: int
    settle_tol: float
    out: str | None = None
    executor: Any = None
    max_workers: int | None = None
    progress: bool = False
    retry_failed: bool = False
    sweeps: list = field(default_factory=list)

    def run(self, batch: list[dict], label: str) -> list[dict]:
        res = run_sweep(dns_task, batch, self.out, executor=self.executor, max_workers=self.max_workers,
                        progress=self.progress, retry_failed=self.retry_failed, label=label)
        self.sweeps.append(res.summary())
        return [_summary(r, self.name, self.first_perturbed, self.settle_window, self.settle_tol) for r in res.records]


def resolve_undecided(runner: "ProbeRunner", rows: list[dict], max_last: int) -> list[dict]:
    """Grid points that are undecided (alive at the end but still drifting: the chain is too short to
    tell) are run again on a chain twice as long, up to ``max_last`` contacts, until they settle or
    decay; each rerun row keeps ``rerun_from`` (the shorter chain). The other rows are unchanged."""
    rows = list(rows)
    while True:
        idx = [k for k, r in enumerate(rows) if r["outcome"] == "undecided" and 2 * r["last"] <= max_last]
        if not idx:
            return rows
        batch = [probe(runner.chain, runner.name, rows[k]["value"], rows[k]["v0"], 2 * rows[k]["last"]) for k in idx]
        for k, row in zip(idx, runner.run(batch, "longer chain")):
            rows[k] = {**row, "rerun_from": rows[k].get("rerun_from", rows[k]["last"])}


def bisect(runner: ProbeRunner, rows: list[dict], impulses: Sequence[float], last: int, max_last: int,
           refine: int) -> dict:
    """Bisection rounds on each impulse's bracket, all impulses at once; an undecided probe is repeated
    on a chain twice as long (up to ``max_last``). Per impulse: bracket, steps, chain length, note, probes."""
    name = runner.name
    state = {}
    for v0 in impulses:
        mine = [r for r in rows if r["v0"] == v0]
        state[v0] = {"bracket": list(bracket(mine)), "last": last, "steps": 0, "note": None, "probes": []}
    for _ in range(refine):
        todo = {}
        for v0, st in state.items():
            a, b = st["bracket"]
            if a is None or b is None or st["note"]:
                continue
            todo[v0] = 0.5 * (a + b)
        if not todo:
            break
        pending = dict(todo)
        while pending:
            batch = [probe(runner.chain, name, mid, v0, state[v0]["last"]) for v0, mid in pending.items()]
            again = {}
            for v0, row in zip(pending, runner.run(batch, "bisection")):
                st = state[v0]
                st["probes"].append(row)
                if row["outcome"] == "settles":
                    st["bracket"][1] = pending[v0]
                    st["steps"] += 1
                elif row["outcome"] == "decays":
                    st["bracket"][0] = pending[v0]
                    st["steps"] += 1
                elif row["outcome"] == "undecided" and 2 * st["last"] <= max_last:
                    st["last"] *= 2
                    again[v0] = pending[v0]
                else:
                    st["note"] = (f"bisection stopped at {name} = {pending[v0]:.6g}: {row['outcome']} on "
                                  f"{st['last']} contacts")
            pending = again
    return state
