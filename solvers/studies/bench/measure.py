"""Measuring one run of a benchmark: the ladder of settings, a measured point, best-of-K timing,
the peak error against the reference and the cost of a line at a target error."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Sequence

from pulsemap.symbolic.errors import PulsemapError

__all__ = ["BenchError", "Ladder", "Point", "best_line", "best_of", "cost_at", "fmt", "peak_error", "quick_ladder", "tolerances"]

TARGET = 1e-6
DNS_METHODS = ("DOP853", "RK45", "Radau", "BDF", "LSODA")
QUICK_METHODS = ("DOP853", "RK45", "LSODA")


class BenchError(PulsemapError):
    """A benchmark that cannot be run as asked."""


@dataclass(frozen=True)
class Ladder:
    """What a benchmark measures: tolerances, methods, baseline settings, repeats."""

    rtols: tuple[float, ...] = (1e-4, 1e-6, 1e-8, 1e-10)
    reference_rtol: float = 1e-12
    check_rtol: float = 1e-11
    methods: tuple[str, ...] = DNS_METHODS
    full_methods: tuple[str, ...] = ("DOP853", "LSODA")
    script: tuple[tuple[float, float], ...] = ((1e-6, 0.01), (1e-8, 0.005), (1e-10, 0.0025))
    repeats: int = 3
    target: float = TARGET
    max_samples: float = 2e7  # baseline (a): numbers held at once (2N x samples); larger grids in segments
    models: bool = True
    baselines: bool = True
    compiled_rtols: tuple[float, ...] = (1e-5, 1e-6, 1e-7, 1e-8, 1e-9)  # the compiled engine's lines
    compiled_methods: tuple[str, ...] = ("RK45", "DOP853")  # its kernels (Dormand-Prince 5(4), DOP853)
    script_rtols: tuple[float, ...] = (1e-6, 1e-7, 1e-8, 1e-9)  # the careful user's script (reference_script.py)
    engines: bool = True  # the compiled engine and the careful user's script
    cold: bool = True  # each of them (and the scipy engine) once more in a fresh process, numba cache empty


def quick_ladder(repeats: int = 1) -> Ladder:
    """A few-seconds version: three tolerances, three methods, one baseline (a) setting."""
    return Ladder(rtols=(1e-5, 1e-7, 1e-9), reference_rtol=1e-11, check_rtol=1e-10, methods=QUICK_METHODS,
                  full_methods=("DOP853",), script=((1e-7, 0.005), (1e-10, 0.002)), repeats=repeats,
                  compiled_rtols=(1e-5, 1e-7, 1e-9), script_rtols=(1e-7, 1e-9))


@dataclass(frozen=True)
class Point:
    """One measured run: what it was, its error against the reference and its best time."""

    kind: str  # "dns", "baseline-b", "baseline-a", "model"
    line: str  # the work-precision line it belongs to (method and mode, or model)
    setting: str  # tolerance / sampling / profile, human-readable
    rtol: float | None
    error: float | None  # a DNS run's max relative peak error vs the reference (a fraction, as rtol); None for a model
    missing: int  # live reference contacts without a value
    time_s: float
    nfev: int | None = None
    note: str = ""
    rms_pct: float | None = None  # a model's error as every output reports it (studies/errors.py), percent
    max_pct: float | None = None  # ... its max, percent
    live_range: tuple[int, int] | None = None  # the contacts that error is taken over


def best_of(run: Callable[[], tuple[object, float]], repeats: int) -> tuple[object, float]:
    """Warm up once, then the fastest of ``repeats`` runs: (last result, best time)."""
    result, _ = run()
    best = math.inf
    for _ in range(max(1, repeats)):
        result, seconds = run()
        best = min(best, seconds)
    return result, best


def best_line(costs: dict, kind: str) -> tuple[float | None, str]:
    """(time, line) of the cheapest line of ``kind`` at the target (``costs``: {"kind|line": (time, how)})."""
    found = [(t, key.split("|", 1)[1]) for key, (t, _) in costs.items() if key.startswith(kind + "|") and t]
    return min(found) if found else (None, "")


def peak_error(peaks: Sequence[float | None], ref: Sequence[float | None]) -> tuple[float | None, int]:
    """(max relative error over contacts where ``ref`` has a value, contacts missing a value)."""
    rel, missing = [], 0
    for p, r in zip(peaks, ref):
        if r is None:
            continue
        if p is None or not math.isfinite(p):
            missing += 1
            continue
        rel.append(abs(p / r - 1.0))
    return (max(rel) if rel else None), missing


def cost_at(points: Sequence[Point], target: float) -> tuple[float | None, str]:
    """Time a line needs for max error ``target`` (see the module docstring for how)."""
    pts = sorted((p for p in points if p.error is not None and p.missing == 0), key=lambda p: -(p.rtol or 0.0))
    if not pts:
        return None, "no complete run"
    below = [p for p in pts if p.error <= target]
    if not below:
        return None, f"no run reached {target:g} (best {min(p.error for p in pts):.2g})"
    for a, b in zip(pts, pts[1:]):
        if a.error > target >= b.error:
            ea, eb = math.log(max(a.error, 1e-300)), math.log(max(b.error, 1e-300))
            ta, tb = math.log(a.time_s), math.log(b.time_s)
            w = (math.log(target) - ea) / (eb - ea) if eb != ea else 1.0
            return math.exp(ta + w * (tb - ta)), f"interpolated between {a.setting} and {b.setting}"
    cheapest = min(below, key=lambda p: p.time_s)
    if pts[0].error <= target:
        return cheapest.time_s, f"every run below {target:g}: cheapest ({cheapest.setting}), an upper bound"
    return cheapest.time_s, f"cheapest run below {target:g} ({cheapest.setting})"


def tolerances(scene, rtol: float) -> dict:
    """rtol and an atol scaled to the scene's strain and velocity scales (extreme v0 too)."""
    from pulsemap.solvers.chain.dns import velocity_scale

    scale = min(scene.velocity, velocity_scale(scene.velocity, scene.exponent))
    return {"rtol": float(rtol), "atol": float(rtol * 1e-2 * scale)}


def fmt(x: float | None, spec: str = ".2e") -> str:
    return "-" if x is None else format(x, spec)
