"""A run's result as CSV, as a short text summary and as a figure in the paper's style."""

from __future__ import annotations

from pulsemap.solvers.studies.errors import DEFINITION, LIVE_FRACTION, counted
from pulsemap.solvers.studies.methods import MODELS, RunError

__all__ = ["LEGEND", "nothing_ran", "plot", "to_csv", "to_text"]


#: The text table shows every contact up to this many rows, else every k-th (``--all``: every contact).
MAX_ROWS = 40
LEGEND = ("peak: the leading-edge maximum of delta_i = x_i - x_(i+1) at contact i (its first maximum in time); "
          "error: " + DEFINITION)
FIRST_ORDER_NOTE = 20.0  # RMS % of the paper's map above which run says why and points to the ranking


def _columns(result: dict) -> list[str]:
    """The DNS (when there is one), the models the run was asked for, in the order asked, then the
    best of the ranking when the run did not compute it (``--rank``)."""
    methods = result["choices"]["methods"]
    cols = ["dns"] if result["peaks"].get("dns") is not None else []
    cols += [m for m in methods if m != "dns" and m in MODELS]
    best = (result.get("best") or {}).get("column")
    return cols + ([best] if best is not None and best not in cols else [])


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{x:.3g} %"


def to_csv(result: dict) -> str:
    """One row per contact: contact, the peak of each method asked for (and of the best of the ranking;
    empty where it has none), and from the DNS whether its pulse is alive, whether the contact is in
    the live range the errors are taken over (studies/errors.py), the arrival time of the peak, the
    pulse speed (contacts per unit time) and the energies of the pulse and of the chain; with masses, the
    velocity peak of bead i (the row's contact i) from the DNS and from each model that gives one."""
    cols = _columns(result)
    dns = result.get("dns") or {}
    extra = [k for k in ("arrival_times", "speed", "pulse_energy", "total_energy") if dns.get(k) is not None]
    names = {"arrival_times": "dns_arrival_time", "speed": "dns_speed", "pulse_energy": "dns_pulse_energy",
             "total_energy": "dns_total_energy"}
    velocity = {}  # column -> {bead: peak}
    for name in ["dns"] + cols:
        given = (result.get(name) or {}).get("velocity_peaks") if isinstance(result.get(name), dict) else None
        if given:
            velocity[f"{name}_velocity_peak"] = dict(zip(given["beads"], given["peaks"]))
    head = (["contact"] + cols + (["dns_alive", "live_range"] if dns else []) + [names[k] for k in extra]
            + list(velocity))
    lines = [",".join(head)]
    alive = dns.get("alive") or [None] * len(result["contacts"])
    span = _live_range(result)
    for k, c in enumerate(result["contacts"]):
        row = [str(c)]
        for name in cols:
            vals = result["peaks"][name]
            row.append("" if vals is None or vals[k] is None else repr(vals[k]))
        if dns:
            row.append("" if alive[k] is None else str(bool(alive[k])).lower())
            row.append(str(span is not None and span[0] <= c <= span[1] and bool(alive[k])).lower())
        for key in extra:
            v = dns[key][k]
            row.append("" if v is None else repr(v))
        for peaks in velocity.values():
            v = peaks.get(c)
            row.append("" if v is None else repr(v))
        lines.append(",".join(row))
    return "\n".join(lines) + "\n"


def _live_range(result: dict) -> list[int] | None:
    """[first, last] contact of the live range the errors are taken over (None without one)."""
    return next((e["live_range"] for e in result["errors"].values() if e.get("live_range")), None)


def _error_line(name: str, err: dict) -> str:
    if err["rms_pct"] is None:
        return (f"  {name:8s} vs DNS: nothing to compare (no contact after the seed where the DNS peak is >= "
                f"{100 * LIVE_FRACTION:g} % of the seed's)")
    a, b = err["live_range"]
    return (f"  {name:8s} vs DNS: RMS {_pct(err['rms_pct'])}, max {_pct(err['max_pct'])} over the live range {a}..{b}"
            + (f" ({counted(err['missing'], 'contact')} without a value count as 100 %)" if err["missing"] else ""))


def _ranking_lines(result: dict) -> list[str]:
    """The ranking (``--rank``), the best model and what it is; a note when the paper's map is far off."""
    ranking = result.get("ranking")
    lines = []
    if ranking:
        span = ranking[0].get("live_range")
        where = f" over the live range {span[0]}..{span[1]}" if span else ""
        lines.append(f"  ranking against this DNS, every model (RMS error %{where}): "
                     + ", ".join(f"{r['model']} {r['rms_pct']:.3g}" for r in ranking))
    best = result.get("best")
    if best:
        lines.append(f"  best of the ranking: {best['model']} (column {best['column']} in the peaks, CSV, plot and JSON)")
    err = result["errors"].get("map")
    if result["choices"]["variant"] != "paper" or err is None or err["rms_pct"] is None \
            or err["rms_pct"] <= FIRST_ORDER_NOTE:
        return lines
    eps = result["scene"]["perturbation"]["eps"]
    note = (f"  the paper's map (Eq. 23, variant paper) is a first-order theory in eps: at eps = {eps:g} it is "
            f"{_pct(err['rms_pct'])} RMS off the DNS; ")
    if best and best["model"] != "map/paper":
        ranked = next(r for r in ranking if r["model"] == best["model"])
        note += f"{best['model']} does best here ({_pct(ranked['rms_pct'])}); "
    elif not ranking:
        note += "`pulsemap run --rank` ranks every model against this DNS; "
    lines.append(note + "`pulsemap table` ranks every model on every paper scene")
    return lines


def _peak_rows(result: dict, cols: list[str], every: int | None) -> list[str]:
    best = (result.get("best") or {}).get("column")
    headers = [f"best: {c}" if c == best and c not in result["choices"]["methods"] else c for c in cols]
    series = [result["peaks"][c] for c in cols]
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
    terms = ""
    if "contact" in sc:
        c = sc["contact"]
        terms += f", contact P = {c['P']} (eps {c['eps']}, contacts >= {c['first_perturbed']})"
    if "masses" in sc:
        terms += f", masses m = {sc['masses']['m']} (beads >= {sc['masses']['first_perturbed']})"
    lines = [
        f"scene {sc['name']}: R = {sc['perturbation']['R']}, eps = {sc['perturbation']['eps']}{terms}, "
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
        full = f" (the full chain: {d['full_chain_because']})" if d.get("full_chain_because") else ""
        lines.append(f"  DNS: {d['method']} rtol {d['rtol']:g}, {d['beads']} beads{full}, {d['stop_reason']}{span}")
        if d.get("energy_drift") is not None:
            lines.append(f"  DNS energy drift (R = 0 conserves energy: the run's accuracy): {d['energy_drift']:.2g} relative")
    for name in dict.fromkeys([*MODELS, *_columns(result)]):
        if name != "dns" and isinstance(result.get(name), dict):
            info = result[name]
            why = next((f"{k}: {info[k]}" if k == "failed" else info[k] for k in ("refused", "failed", "note") if k in info), None)
            status = f" [{why}]" if why is not None else ""
            lines.append(f"  {name}: {info.get('model', '')}{status}")
    for name, err in result["errors"].items():
        lines.append(_error_line(name, err))
    lines += _ranking_lines(result)
    t = result["timings_s"]
    lines.append("  time: " + ", ".join(f"{k} {v:.4g} s" for k, v in t.items()))
    cols = _columns(result)
    if cols:
        lines += _peak_rows(result, cols, every)
    for w in result["warnings"]:
        lines.append(f"  warning: {w}")
    return "\n".join(lines)


def nothing_ran(result: dict) -> str:
    """Why no method produced a single peak ("" when something ran): the run is then an error."""
    if any(v is not None and any(x is not None for x in v) for v in result["peaks"].values()):
        return ""
    refused = [f"{m}: {result[m].get('refused') or 'failed: ' + result[m]['failed']}" for m in result["choices"]["methods"]
               if isinstance(result.get(m), dict) and ("refused" in result[m] or "failed" in result[m])]
    if refused:
        return "nothing ran: " + "; ".join(refused)
    why = [w for w in result.get("warnings", []) if not w.startswith("eps = ")]  # what stopped each method
    return "nothing ran: no method produced a peak" + (": " + "; ".join(why) if why else
                                                       " (no method reported why: please report this scene)")


def plot(result: dict, path: str, log_y: bool = False) -> None:
    """The paper's style: DNS as +, map as dots, long-wave law as a line, the DNS's stop marked
    (data/plotting.peaks_figure; matplotlib, optional)."""
    from pulsemap.solvers.data.plotting import figures, peaks_figure, save

    save(peaks_figure(result, figures(RunError), log_y), path)
