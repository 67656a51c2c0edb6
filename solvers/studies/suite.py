"""Stiff and extreme cases of paper Eq. 1, each a scene, run from one command (``pulsemap suite``).

The scenes live in solvers/scenes/suite/ (stiff damping eps*mu = 10, 100, 1000; a stiff
foundation; v0 = 1e-6 and 1e6; eps = 1; n = 1.1, 2.5, 3; N = 10000; the Van der Pol chain near
its fold; an unstable foundation for the blow-up guard; a non-stiff yardstick). For each one:
``run_scene`` with the moving-window DNS (method 'auto' picks explicit or implicit), the map and
the long-wave law; then a second DNS at 100x tighter rtol with the other kind of method
(implicit LSODA on the scipy engine if the first was explicit, explicit RK45 on the compiled
engine if it was implicit), over the first CHECK_CONTACTS contacts at most (the ``vs`` column
names where it stops), gives the DNS error. Reported: method
chosen, DNS time, DNS error, the map's error against the DNS, the stop reason, warnings, and a
status. A run that returns a non-finite number anywhere, or ends without a stop reason, FAILs;
one whose map or long-wave law misses the DNS by more than 50 % while the run output warned
about nothing of the kind is SILENT (outside the models' range without saying so).
"""

from __future__ import annotations

import math
import time
from importlib import resources
from pathlib import Path
from typing import Callable, Sequence

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.data.scene import with_overrides
from pulsemap.solvers.studies.progress import Progress

STIFF_SCENE, YARDSTICK = "damp-100", "nonstiff"
STIFF_RATIO_TARGET = 5.0  # stiff damping's DNS may cost this x the non-stiff yardstick's: stiffness must not price it out
RATIO_REPEATS = 3  # the stiff ratio's two DNS times: best of at least this many (a process's first call of
#                    a kernel loads it from numba's cache, which can take longer than the run itself)
SILENT_ERROR = 0.5  # a model this far off the DNS (max relative error) must have been warned about
CHECK_CONTACTS = 200  # contacts the check run covers at most (from the scene's first)


class SuiteError(PulsemapError):
    """A suite that cannot be run as asked."""


def suite_dir() -> Path:
    """Directory of the suite's scene files (shipped as package data)."""
    return Path(str(resources.files("pulsemap.solvers.data") / "scenes" / "suite"))


def suite_scenes() -> list[str]:
    """Names of the suite's scenes, sorted."""
    return sorted(p.stem for p in suite_dir().glob("*.toml"))


def resolve(name: str) -> str:
    """A suite scene name -> its file; anything else (built-in name, path) as given."""
    path = suite_dir() / f"{name}.toml"
    return str(path) if path.is_file() else name


def check_names(names: Sequence[str]) -> None:
    """Every name must be a suite scene, a built-in scene or an existing file: else a SuiteError
    naming it (with the closest known name), before anything runs."""
    from pulsemap.symbolic.errors import closest
    from pulsemap.solvers.data.scene import ALIASES, builtin_scenes

    known = suite_scenes() + builtin_scenes() + list(ALIASES)
    for name in names:
        if not isinstance(name, str):
            raise SuiteError(f"suite scene names must be strings, got {type(name).__name__}")
        if name in known or Path(resolve(name)).expanduser().is_file():
            continue
        close = closest(Path(name).stem, known)
        hint = f" (did you mean '{close}'?)" if close else ""
        raise SuiteError(f"unknown scene {name!r}{hint}: give a suite scene (pulsemap suite --list), "
                         "a built-in name (pulsemap scenes) or the path of a .toml file")


def non_finite(obj, where: str = "") -> list[str]:
    """Paths of every NaN or infinity inside a JSON-like object."""
    if isinstance(obj, float):
        return [] if math.isfinite(obj) else [where or "<value>"]
    if isinstance(obj, dict):
        return [p for k, v in obj.items() for p in non_finite(v, f"{where}.{k}" if where else str(k))]
    if isinstance(obj, (list, tuple)):
        return [p for i, v in enumerate(obj) for p in non_finite(v, f"{where}[{i}]")]
    return []


def max_rel(values: Sequence[float | None], ref: Sequence[float | None]) -> tuple[float | None, int]:
    """(max relative difference where both have a value, contacts only one of them has)."""
    rel, odd = [], 0
    for v, r in zip(values, ref):
        if (v is None) != (r is None):
            odd += 1
        elif v is not None:
            rel.append(abs(v / r - 1.0))
    return (max(rel) if rel else None), odd


def silent_model_errors(row: dict) -> list[str]:
    """Models off the DNS by more than SILENT_ERROR while run output warned about none of it."""
    warned = " ".join(row.get("warnings", [])).lower()
    out = []
    for key, model, words in (("map_error", "map", ("map", "eps", "reduced models")),
                              ("longwave_error", "long-wave law", ("long-wave", "eps", "reduced models"))):
        err = row.get(key)
        if err is not None and err > SILENT_ERROR and not any(w in warned for w in words):
            out.append(f"{model} off the DNS by {100 * err:.0f} % (max rel) and nothing in the run output warned")
    return out


def other_method(method: str) -> str:
    """The check run's method: implicit (LSODA, scipy engine) for an explicit first run, explicit for an
    implicit one (RK45: the compiled engine, so the stiff cases' check costs milliseconds)."""
    from pulsemap.solvers.chain.dns import EXPLICIT_METHODS
    from pulsemap.solvers.chain.methods import auto_pick

    return auto_pick("scipy stiff") if method in EXPLICIT_METHODS else auto_pick("explicit")


def check_contacts(contacts: tuple[int, int]) -> tuple[int, int]:
    """The contacts the check run covers: the scene's, at most CHECK_CONTACTS of them (the implicit check
    runs on the scipy engine at ~1 ms a contact: the 9975 contacts of chain10000 took 12 s of CPU)."""
    first, last = contacts
    return first, min(last, first + CHECK_CONTACTS - 1)


def run_case(ref: str, *, check: bool = True, repeats: int = 1) -> dict:
    """Run one suite scene (name or path) and report it (see the module docstring)."""
    from pulsemap.solvers.studies.run import run_scene
    from pulsemap.solvers.data.scene import load_scene

    wall0 = time.perf_counter()
    try:
        scene = load_scene(resolve(ref))
    except PulsemapError as exc:  # a refused scene is a clear message, not a crash
        return {"scene": Path(ref).stem, "status": "refused", "message": str(exc), "wall_s": 0.0}
    row: dict = {"scene": scene.name, "R": scene.perturbation.text, "eps": scene.perturbation.eps,
                 "v0": scene.velocity, "n": scene.exponent, "contacts": list(scene.contacts),
                 "methods": list(scene.methods)}
    try:
        result = run_scene(scene, dns_window="auto")
        times = [result["timings_s"].get("dns", math.nan)]
        for _ in range(max(0, repeats - 1)):
            times.append(run_scene(scene, methods=["dns"], dns_window="auto")["timings_s"]["dns"])
    except PulsemapError as exc:  # a refused scene is a clear message, not a crash
        row.update(status="refused", message=str(exc), wall_s=time.perf_counter() - wall0)
        return row
    dns = result.get("dns", {})
    row.update(method=dns.get("method"), rtol=dns.get("rtol"), dns_time_s=min(times),
               stop_reason=dns.get("stop_reason"), live_contacts=len(dns.get("live_contacts", [])),
               warnings=list(result["warnings"]))
    errors = result.get("errors", {})
    for key, model in (("map_error", "map"), ("longwave_error", "longwave")):  # studies/errors.py, as a fraction
        pct = (errors.get(model) or {}).get("max_pct")
        row[key] = None if pct is None else pct / 100.0
    if check and result["peaks"]["dns"] is not None:
        second = other_method(dns["method"])
        span = check_contacts(scene.contacts)
        tighter = with_overrides(scene, dns={"rtol": max(dns["rtol"] / 100.0, 1e-13),
                                            "atol": scene.dns["atol"] / 100.0, "method": second}, contacts=span)
        check_run = run_scene(tighter, methods=["dns"], dns_window="auto")
        err, odd = max_rel(result["peaks"]["dns"], check_run["peaks"]["dns"])  # zip: over the check's contacts
        part = "" if span == tuple(scene.contacts) else f" to {span[1]}"
        row.update(dns_error=err, dns_error_vs=f"{second} rtol {tighter.dns['rtol']:g}{part}",
                   dns_error_mismatch=odd, check_time_s=check_run["timings_s"]["dns"],
                   check_stop_reason=check_run["dns"]["stop_reason"])
    bad = non_finite(result)
    row["wall_s"] = time.perf_counter() - wall0
    if bad:
        row.update(status="FAIL", message="non-finite values in the result: " + ", ".join(bad[:5]))
    elif not row.get("stop_reason"):
        row.update(status="FAIL", message="the DNS ended without a stop reason")
    elif "blow-up" in row["stop_reason"]:
        row.update(status="stopped", message=row["stop_reason"])
    elif silent := silent_model_errors(row):
        row.update(status="SILENT", message="; ".join(silent))
    else:
        row.update(status="ok" if not row["warnings"] else "ok, warned",
                   message="; ".join(row["warnings"]) if row["warnings"] else "")
    return row


def run_suite(names: Sequence[str] | None = None, *, check: bool = True, repeats: int = 1,
              log: Callable[[str], None] = lambda s: None) -> dict:
    """Run the suite (all its scenes by default) and the stiff-damping time ratio (its two DNS times
    best of at least RATIO_REPEATS, whatever ``repeats`` says)."""
    names = list(names) if names else suite_scenes()
    check_names(names)
    rows = []
    report = Progress("suite", len(names), sink=log)
    for name in names:
        report.start(name)
        timed = max(repeats, RATIO_REPEATS) if name in (STIFF_SCENE, YARDSTICK) else repeats
        rows.append(run_case(name, check=check, repeats=timed))
        r = rows[-1]
        report.finish(name, r["status"], r.get("wall_s", 0))
    by = {r["scene"]: r for r in rows}
    ratio = None
    if STIFF_SCENE in by and YARDSTICK in by and by[YARDSTICK].get("dns_time_s"):
        ratio = by[STIFF_SCENE].get("dns_time_s", math.nan) / by[YARDSTICK]["dns_time_s"]
    return {"cases": rows, "stiff_ratio": {"scene": STIFF_SCENE, "yardstick": YARDSTICK, "ratio": ratio,
                                           "target": STIFF_RATIO_TARGET,
                                           "met": None if ratio is None else bool(ratio <= STIFF_RATIO_TARGET)}}


def _pct(x: float | None) -> str:
    """A relative error in percent (the unit of every error pulsemap prints)."""
    return "-" if x is None else f"{100.0 * x:.3g}"


def to_text(report: dict) -> str:
    """The suite table (errors in percent: max relative error of the DNS against its check run and of
    the map against the DNS), then the warnings and messages, then the stiff ratio."""
    from pulsemap.solvers.studies.bench import fmt

    head = (f"{'scene':18s} {'status':11s} {'method':7s} {'dns [s]':>8s} {'dns err %':>9s} {'vs':24s} "
            f"{'map err %':>9s} {'live':>5s}  stop reason")
    lines = [head, "-" * len(head)]
    for r in report["cases"]:
        if r["status"] == "refused":
            lines.append(f"{r['scene']:18s} {'refused':11s} {r['message']}")
            continue
        lines.append(f"{r['scene']:18s} {r['status']:11s} {r.get('method') or '-':7s} "
                     f"{fmt(r.get('dns_time_s'), '8.3f'):>8s} {_pct(r.get('dns_error')):>9s} "
                     f"{r.get('dns_error_vs', '-'):24s} {_pct(r.get('map_error')):>9s} {r.get('live_contacts', 0):5d}"
                     f"  {r.get('stop_reason', '')}")
    lines.append("")
    for r in report["cases"]:
        for w in r.get("warnings", []):
            lines.append(f"{r['scene']}: warning: {w}")
        if r["status"] in ("FAIL", "stopped", "SILENT"):
            lines.append(f"{r['scene']}: {r['status']}: {r['message']}")
    s = report["stiff_ratio"]
    if s["ratio"] is not None:
        lines.append(f"\nstiff damping: time({s['scene']}) / time({s['yardstick']}) = {s['ratio']:.2f} "
                     f"(each best of {RATIO_REPEATS} runs or more; target <= {s['target']:g}: {'met' if s['met'] else 'NOT met'})")
    return "\n".join(lines)
