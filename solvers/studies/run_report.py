"""A run's result as CSV, as a short text summary and as a figure in the paper's style."""

from __future__ import annotations

from pulsemap.solvers.studies.methods import MODELS, RunError

__all__ = ["plot", "to_csv", "to_text"]


def _columns(result: dict) -> list[str]:
    """dns, map, longwave, then every other model that has peaks in this result."""
    extra = [m for m in MODELS if m not in ("map", "longwave") and result["peaks"].get(m) is not None]
    return ["dns", "map", "longwave"] + extra


def to_csv(result: dict) -> str:
    """One row per contact: contact, dns, map, longwave, other models run (empty where not computed)."""
    cols = _columns(result)
    lines = ["contact," + ",".join(cols) + ",dns_alive"]
    alive = (result.get("dns") or {}).get("alive") or [None] * len(result["contacts"])
    for k, c in enumerate(result["contacts"]):
        row = [str(c)]
        for name in cols:
            vals = result["peaks"][name]
            row.append("" if vals is None or vals[k] is None else repr(vals[k]))
        row.append("" if alive[k] is None else str(bool(alive[k])).lower())
        lines.append(",".join(row))
    return "\n".join(lines) + "\n"


def to_text(result: dict) -> str:
    """A short human-readable summary of a run."""
    sc = result["scene"]
    ch = result["choices"]
    lines = [
        f"scene {sc['name']}: R = {sc['perturbation']['R']}, eps = {sc['perturbation']['eps']}, "
        f"v0 = {sc['excitation']['velocity']}, contacts {result['contacts'][0]}..{result['contacts'][-1]}",
        f"  profile {ch['profile']}, map variant {ch['variant']}, methods {', '.join(ch['methods'])}",
    ]
    if "seed" in result:
        s = result["seed"]
        lines.append(f"  seed: A_{s['contact']} = {s['A']:.6g} (peak {s['peak']:.6g}, from {s['from']})")
    if "dns" in result:
        d = result["dns"]
        lines.append(f"  DNS: {d['method']} rtol {d['rtol']:g}, {d['beads']} beads, {d['stop_reason']}")
    for name in MODELS:
        if isinstance(result.get(name), dict):
            info = result[name]
            status = f" [{info['refused']}]" if "refused" in info else ""
            lines.append(f"  {name}: {info.get('model', '')}{status}")
    for name, err in result["errors"].items():
        if err["max_rel"] is None:
            lines.append(f"  {name:8s} vs DNS: nothing to compare ({err['missing']} live contacts without a value)")
        else:
            lines.append(
                f"  {name:8s} vs DNS: max rel {err['max_rel']:.3g}, rms rel {err['rms_rel']:.3g} over "
                f"{err['compared']} live contacts" + (f" ({err['missing']} without a value)" if err["missing"] else "")
                + (f"; max rel {err['max_rel_strong']:.3g} while the DNS peak >= 10 % of its entry value"
                   if err.get("max_rel_strong") is not None else "")
            )
        live = err.get("live") or {}
        if live.get("rms_rel_all") is not None:
            a, b = live["contacts"]
            lines.append(f"  {'':8s}   live range {a}..{b} (DNS peak >= 2 % of the seed's): rms rel "
                         f"{live['rms_rel_all']:.3g}, max rel {live['max_rel_all']:.3g}"
                         + (f" ({live['missing']} contacts without a value count as 1)" if live["missing"] else ""))
    t = result["timings_s"]
    lines.append("  time: " + ", ".join(f"{k} {v:.4g} s" for k, v in t.items()))
    cols = _columns(result)
    lines.append(f"  {'contact':>7s} " + " ".join(f"{c:>12s}" for c in cols))
    step = max(1, len(result["contacts"]) // 12)
    for k in range(0, len(result["contacts"]), step):
        row = [f"  {result['contacts'][k]:7d}"]
        for name in cols:
            vals = result["peaks"][name]
            row.append(f"{'-' if vals is None or vals[k] is None else format(vals[k], '.6g'):>12s}")
        lines.append(" ".join(row))
    for w in result["warnings"]:
        lines.append(f"  warning: {w}")
    return "\n".join(lines)


def plot(result: dict, path: str, log_y: bool = False) -> None:
    """The paper's style: DNS as +, map as dots, long-wave law as a line, the DNS's stop marked
    (data/plotting.peaks_figure; matplotlib, optional)."""
    from pulsemap.solvers.data.plotting import peaks_figure, pyplot, save

    plt = pyplot(RunError)
    save(peaks_figure(result, plt, log_y), plt, path)
