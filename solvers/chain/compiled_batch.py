"""Many chains of paper Eq. 1 in one compiled call: the compiled engine over a batch (numba prange).

    x_i'' = (x_{i-1} - x_i)_+^n - (x_i - x_{i+1})_+^n + sum_m c_m[i] x_i^(a_m) v_i^(b_m)     (Eq. 1)

For ensembles, sweeps and scans: chains that share n, the contacts, the tolerances and the
monomials of R (its exponents) but differ in v0 and in the coefficients (eps, parameters, per-bead
draws). Each chain runs exactly as ``simulate(engine="compiled")`` would (the kernel its method and
force call for: Dormand-Prince 5(4), DOP853 when named, Rodas4 for a stiff force under 'auto'; same
arithmetic: identical peaks), the chains spread over the cores, one parallel call per kernel used.
"""

# numba cache stamp: f6f760c5832184af
from __future__ import annotations

import time as _time
from dataclasses import replace
from typing import Sequence

import numpy as np

from pulsemap.solvers.chain.compiled import drive, prepare, result
from pulsemap.solvers.chain.compiled_dop853 import run as run_dop853
from pulsemap.solvers.chain.compiled_kernel import run
from pulsemap.solvers.chain.compiled_stiff import run as run_rodas4
from pulsemap.solvers.chain.equations import DNSResult, default_max_steps, default_t_max
from pulsemap.solvers.chain.force_table import MonomialTable
from pulsemap.solvers.chain.jit import njit, prange
from pulsemap.solvers.chain.peaks import StopRules
from pulsemap.solvers.chain.plan import EXPLICIT_METHODS, HIGH_ORDER_METHOD, METHOD, STIFF_METHOD, compiled_kernel
from pulsemap.solvers.chain.scaling import DIRECT_RANGE, needs_rescaling
from pulsemap.solvers.chain.window import WindowRule, WindowSpec, resolve_rule, window_accuracy_for

METHODS = ("auto",) + EXPLICIT_METHODS


@njit(parallel=True, cache=True)
def run_many(Y, F, FS, ST, CF, CI, PEAKS, TIMES, PULSE, TOTAL, exps, COEF, codes):
    """compiled_kernel.run (Dormand-Prince 5(4)) for every chain b (row b of each array), in parallel."""
    for b in prange(Y.shape[0]):
        codes[b] = run(Y[b], F[b], FS[b], ST[b], CF[b], CI[b], PEAKS[b], TIMES[b], PULSE[b], TOTAL[b], exps,
                       COEF[b])


@njit(parallel=True, cache=True)
def run_many_dop853(Y, F, FS, ST, CF, CI, PEAKS, TIMES, PULSE, TOTAL, exps, COEF, codes):
    """run_many with compiled_dop853.run."""
    for b in prange(Y.shape[0]):
        codes[b] = run_dop853(Y[b], F[b], FS[b], ST[b], CF[b], CI[b], PEAKS[b], TIMES[b], PULSE[b], TOTAL[b], exps,
                              COEF[b])


@njit(parallel=True, cache=True)
def run_many_rodas4(Y, F, FS, ST, CF, CI, PEAKS, TIMES, PULSE, TOTAL, exps, COEF, codes):
    """run_many with compiled_stiff.run (Rodas4)."""
    for b in prange(Y.shape[0]):
        codes[b] = run_rodas4(Y[b], F[b], FS[b], ST[b], CF[b], CI[b], PEAKS[b], TIMES[b], PULSE[b], TOTAL[b], exps,
                              COEF[b])


BATCH_KERNELS = {METHOD: run_many, HIGH_ORDER_METHOD: run_many_dop853, STIFF_METHOD: run_many_rodas4}


def kernel_for(table: MonomialTable, velocity: float, exponent: float, method: str) -> tuple[str, str]:
    """The kernel simulate would run for this chain (plan.compiled_kernel) and the reason its result gives."""
    kernel, why = compiled_kernel(table, velocity, exponent, method)
    return kernel, f"{why}, batch of chains"


def _coefficients(tables: Sequence[MonomialTable]) -> tuple[np.ndarray, np.ndarray]:
    """Shared exponents and every chain's kernel coefficients stacked, (B, M, L) or in the dense form
    (B, 2, 4, L) (MonomialTable.kernel_args; short tables padded with their last column, which is
    what the kernel reads past it anyway)."""
    exps = tables[0].exponents
    if any(t.exponents.shape != exps.shape or np.any(t.exponents != exps) for t in tables):
        raise ValueError("simulate_many: every chain's R must have the same monomials (exponents)")
    each = [t.kernel_args[1] for t in tables]
    width = max(c.shape[-1] for c in each)
    coef = np.empty((len(tables), *each[0].shape[:-1], width))
    for b, c in enumerate(each):
        coef[b, ..., : c.shape[-1]] = c
        coef[b, ..., c.shape[-1]:] = c[..., -1:]
    return exps, coef


def simulate_many(
    beads: int,
    exponent: float,
    velocities: Sequence[float],
    contacts: tuple[int, int],
    tables: Sequence[MonomialTable | None],
    *,
    window: "WindowSpec | str | int | WindowRule | None" = "auto",
    rtol: float = 1e-10,
    atol: float = 1e-12,
    stop: StopRules | None = None,
    method: str = "auto",
) -> list[DNSResult]:
    """One DNSResult per chain b (velocity ``velocities[b]``, on-site force ``tables[b]``, None: R = 0),
    as ``simulate(..., engine="compiled", method=method)`` gives it (the same kernel, window rule for
    the same rtol and window accuracy, and numbers); ``method``: 'auto', 'RK45' or 'DOP853'.
    ``wall_time_s`` is the batch's time / chains."""
    from pulsemap.solvers.chain.dns import validate

    if len(velocities) != len(tables) or not len(tables):
        raise ValueError(f"simulate_many needs one velocity per table, got {len(velocities)} and {len(tables)}")
    if method not in METHODS:
        raise ValueError(f"simulate_many runs the compiled kernels: method must be one of {', '.join(METHODS)}, "
                         f"got {method!r} (for {method!r} call simulate once per chain)")
    first, last = 0, 0
    stop = StopRules() if stop is None else stop
    for v in velocities:
        first, last = validate(beads, exponent, v, contacts, METHOD, rtol, atol, stop)
        if needs_rescaling(float(v)):
            lo, hi = DIRECT_RANGE
            raise ValueError(f"simulate_many: velocity {v!r} lies outside {lo:g}..{hi:g}, where simulate runs the chain "
                             "rescaled to v0 = 1 (chain/scaling.py); call simulate for that chain")
    given = [t for t in tables if t is not None]
    shared = given[0].exponents if given else MonomialTable.zero().exponents
    full = [MonomialTable(shared, np.zeros((shared.shape[0], 1))) if t is None else t for t in tables]
    if any(t.constant_term for t in full):
        raise ValueError("simulate_many: R(0, 0) != 0 (a constant term) in some chain's table")
    spec = WindowSpec.of(window)
    rule = None if spec is None else resolve_rule(spec.size, window_accuracy_for(rtol, spec.accuracy))
    budget = default_max_steps(last) if stop.max_steps is None else int(stop.max_steps)
    kernels = [kernel_for(t, float(v), float(exponent), method) for v, t in zip(velocities, full)]
    runs = [prepare(int(beads), float(exponent), float(v), (first, last), t, rule=rule, rtol=rtol, atol=atol,
                    stop=replace(stop, max_steps=budget, t_max=default_t_max(last, float(v), float(exponent))
                                 if stop.t_max is None else float(stop.t_max)), method=k)
            for v, t, (k, _) in zip(velocities, tables, kernels)]
    codes = np.zeros(len(runs), dtype=np.int64)
    wall0 = _time.perf_counter()
    for kernel, batch in BATCH_KERNELS.items():
        group = [b for b, (k, _) in enumerate(kernels) if k == kernel]
        if group:
            codes[group] = _run_group([runs[b] for b in group], [full[b] for b in group], batch)
    wall = (_time.perf_counter() - wall0) / len(runs)
    return [result(r, int(c), wall, why) for r, c, (_, why) in zip(runs, codes, kernels)]


def _run_group(runs: list, tables: list, batch) -> np.ndarray:
    """The chains of one kernel in one parallel call (``batch``), then each on alone where it asked for
    room (compiled.drive); their stop codes."""
    exps, coef = _coefficients(tables)
    stack = {name: np.stack([getattr(r, name) for r in runs])
             for name in ("y", "f", "fs", "st", "cf", "ci", "peaks", "times", "pulse_e", "total_e")}
    codes = np.zeros(len(runs), dtype=np.int64)
    batch(stack["y"], stack["f"], stack["fs"], stack["st"], stack["cf"], stack["ci"], stack["peaks"],
          stack["times"], stack["pulse_e"], stack["total_e"], exps, coef, codes)
    for b, r in enumerate(runs):
        for name, arr in stack.items():
            setattr(r, name, arr[b].copy())
        codes[b] = drive(r, int(codes[b]))  # a chain that asked for room goes on alone
    return codes
