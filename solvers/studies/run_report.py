"""A run's result as CSV, as a short text summary and as a figure in the paper's style."""

from __future__ import annotations

from pulsemap.solvers.studies.methods import MODELS, RunError

__all__ = ["LEGEND", "nothing_ran", "plot", "to_csv", "to_text"]


#: The text table shows every contact up to this many rows, else every k-th (``--all``: every contact).
MAX_ROWS = 40
LEGEND = ("peak: the leading-edge maximum of delta_i = x_i - x_(i+1) at contact i (its first maximum in time); "
          "error: |model peak - DNS peak| / DNS peak in percent, over the contacts where the DNS's primary pulse is "
          "alive (max, RMS)")
FIRST_ORDER_NOTE = 20.0  # RMS % of the paper's map above which run says why and points to the ranking


def _columns(result: dict) -> list[str]:
    """The DNS (when there is one), then the models the run was asked for, in the order asked."""
    methods = result["choices"]["methods"]
    cols = ["dns"] if result["peaks"].get("dns") is not None else []
    return cols + [m for m in methods if m != "dns" and m in MODELS]


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{100.0 * x:.3g} %"


def to_csv(result: dict) -> str:
    """One row per contact: contact, the peak of each method asked for (empty where it has none), and
    from the DNS whether its pulse is alive, the arrival time of the peak, the pulse speed (contacts
    per unit time) and the energies of the pulse and of the chain."""
    cols = _columns(result)
    dns = result.get("dns") or {}
    extra = [k for k in ("arrival_times", "speed", "pulse_energy", "total_energy") if dns.get(k) is not None]
    names = {"arrival_times": "dns_arrival_time", "speed": "dns_speed", "pulse_energy": "dns_pulse_energy",
             "total_energy": "dns_total_energy"}
    head = ["contact"] + cols + (["dns_alive"] if dns else []) + [names[k] for k in extra]
    lines = [",".join(head)]
    alive = dns.get("alive") or [None] * len(result["contacts"])
    for k, c in enumerate(result["contacts"]):
        row = [str(c)]
        for name in cols:
            vals = result["peaks"][name]
            row.append("" if vals is None or vals[k] is None else repr(vals[k]))
        if dns:
            row.append("" if alive[k] is None else str(bool(alive[k])).lower())
        for key in extra:
            v = dns[key][k]
            row.append("" if v is None else repr(v))
        lines.append(",".join(row))
    return "\n".join(lines) + "\n"


def _error_line(name: str, err: dict) -> str:
    if err["max_rel"] is None:
        line = f"  {name:8s} vs DNS: nothing to compare ({err['missing']} live contacts without a value)"
    else:
        line = (f"  {name:8s} vs DNS: max {_pct(err['max_rel'])}, RMS {_pct(err['rms_rel'])} over {err['compared']} live "
                "contacts" + (f" ({err['missing']} without a value)" if err["missing"] else "")
                + (f"; max {_pct(err['max_rel_strong'])} while the DNS peak >= 10 % of its entry value"
                   if err.get("max_rel_strong") is not None else ""))
    live = err.get("live") or {}
    if live.get("rms_rel_all") is not None:
        a, b = live["contacts"]
        line += (f"\n  {'':8s}   live range {a}..{b} (DNS peak >= 2 % of the seed's): RMS {_pct(live['rms_rel_all'])}, "
                 f"max {_pct(live['max_rel_all'])}"
                 + (f" ({live['missing']} contacts without a value count as 100 %)" if live["missing"] else ""))
    return line


def _ranking_lines(result: dict) -> list[str]:
    ranking = result.get("ranking") or []
    if not ranking:
        return []
    span = ranking[0].get("live_contacts")
    where = f" over the live range {span[0]}..{span[1]}" if span else ""
    lines = [f"  ranking against this DNS, every model (RMS error %{where}, a model that ended counts 100 %): "
             + ", ".join(f"{r['model']} {r['rms_pct']:.3g}" for r in ranking)]
    paper = next((r for r in ranking if r["model"] == "map/paper"), None)
    best = ranking[0]
    if paper is not None and paper is not best and paper["rms_pct"] > FIRST_ORDER_NOTE:
        eps = result["scene"]["perturbation"]["eps"]
        lines.append(f"  the paper's map (Eq. 23, variant paper) is a first-order theory in eps: at eps = {eps:g} it is "
                     f"{paper['rms_pct']:.3g} % RMS off the DNS; {best['model']} does best here ({best['rms_pct']:.3g} %); "
                     "`pulsemap table` ranks every model on every paper scene")
    return lines


def _peak_rows(result: dict, cols: list[str], every: int | None) -> list[str]:
    ranking = result.get("ranking") or []
    best = ranking[0] if ranking else None
    shown_best = best is not None and best["model"] not in cols and not (
        best["model"] == f"map/{result['choices']['variant']}" and "map" in cols)
    headers = [("dns" if c == "dns" else c) for c in cols] + ([f"best: {best['model']}"] if shown_best else [])
    series = [result["peaks"][c] for c in cols] + ([best["peaks"]] if shown_best else [])
    width = max([12] + [len(h) + 1 for h in headers])
    contacts = result["contacts"]
    valued = [k for k in range(len(contacts)) if any(v is not None and v[k] is not None for v in series)]
    n = valued[-1] + 1 if valued else 0  # rows past the last value of any method are summarised in one line
    step = 1 if every is None else max(1, every)
    if every is None and n > MAX_ROWS:
        step = -(-n // MAX_ROWS)
    lines = [f"  {'contact':>7s} " + " ".join(f"{h:>{width}s}" for h in headers)]
    for k in range(0, n, step):
        row = [f"  {contacts[k]:7d}"]
        for vals in series:
            row.append(f"{'-' if vals is None or vals[k] is None else format(vals[k], '.6g'):>{width}s}")
        lines.append(" ".join(row))
    if n < len(contacts):
        lines.append(f"  {contacts[n]}..{contacts[-1]}: no method has a pulse there")
    if step > 1:
        lines.append(f"  (every {_ordinal(step)} contact of {n}: --all for all, --json or --csv for the numbers)")
    return lines


def _ordinal(k: int) -> str:
    suffix = "th" if 10 <= k % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(k % 10, "th")
    return f"{k}{suffix}"


def to_text(result: dict, every: int | None = None) -> str:
    """A short human-readable summary of a run. ``every``: show every k-th contact (1: all); by
    default all up to MAX_ROWS rows, else evenly thinned with a note saying so."""
    sc = result["scene"]
    ch = result["choices"]
    lines = [
        f"scene {sc['name']}: R = {sc['perturbation']['R']}, eps = {sc['perturbation']['eps']}, "
        f"v0 = {sc['excitation']['velocity']}, contacts {result['contacts'][0]}..{result['contacts'][-1]}",
        f"  profile {ch['profile']}, map variant {ch['variant']}, methods {', '.join(ch['methods'])}",
        "  " + LEGEND,
    ]
    if "seed" in result:
        s = result["seed"]
        lines.append(f"  seed: A_{s['contact']} = {s['A']:.6g} (peak {s['peak']:.6g}, from {s['from']})")
    if "dns" in result:
        d = result["dns"]
        live = d.get("live_contacts") or []
        span = f"; primary pulse alive at contacts {live[0]}..{live[-1]}" if live else "; no live primary pulse"
        lines.append(f"  DNS: {d['method']} rtol {d['rtol']:g}, {d['beads']} beads, {d['stop_reason']}{span}")
        if d.get("energy_drift") is not None:
            lines.append(f"  DNS energy drift (R = 0 conserves energy: the run's accuracy): {d['energy_drift']:.2g} relative")
    for name in MODELS:
        if isinstance(result.get(name), dict):
            info = result[name]
            status = f" [{info['refused']}]" if "refused" in info else ""
            lines.append(f"  {name}: {info.get('model', '')}{status}")
    for name, err in result["errors"].items():
        lines.append(_error_line(name, err))
    lines += _ranking_lines(result)
    t = result["timings_s"]
    lines.append("  time: " + ", ".join(f"{k} {v:.4g} s" for k, v in t.items()))
    cols = _columns(result)
    if cols or result.get("ranking"):
        lines += _peak_rows(result, cols, every)
    for w in result["warnings"]:
        lines.append(f"  warning: {w}")
    return "\n".join(lines)


def nothing_ran(result: dict) -> str:
    """Why no method produced a single peak ("" when something ran): the run is then an error."""
    if any(v is not None and any(x is not None for x in v) for v in result["peaks"].values()):
        return ""
    refused = [f"{m}: {result[m]['refused']}" for m in result["choices"]["methods"]
               if isinstance(result.get(m), dict) and "refused" in result[m]]
    if refused:
        return "nothing ran: " + "; ".join(refused)
    why = [w for w in result.get("warnings", []) if not w.startswith("eps = ")]  # what stopped each method
    return "nothing ran: no method produced a peak" + (": " + "; ".join(why) if why else
                                                       " (no method reported why: please report this scene)")


def plot(result: dict, path: str, log_y: bool = False) -> None:
    """The paper's style: DNS as +, map as dots, long-wave law as a line, the DNS's stop marked
    (data/plotting.peaks_figure; matplotlib, optional)."""
    from pulsemap.solvers.data.plotting import peaks_figure, pyplot, save

    plt = pyplot(RunError)
    save(peaks_figure(result, plt, log_y), plt, path)
