"""Iterate the amplitude map of Eq. 23 along the chain (generated residuals and Jacobian).

At contact i, with A_{i-1} known, solve F1 = F2 = 0 for (A_i, A_{i+1}) (variants ``paper``,
``corrected``) or F1 = 0 for A_i (variant ``1d``), keep A_i, and move on (the three-stage scheme
after Eq. 23). Newton's method in log-amplitudes with the generated Jacobian; when it fails, a
bracketing fallback (eliminate A_{i+1} from F2, then bisect F1 in A_i). When no positive root
exists (status "no root": the reduction breaks down, e.g. a destabilising foundation has pumped
A up beyond the map's last solution) or A falls below ``death_fraction`` of its seed (status
"died"), the iteration stops at that contact and its message names the contact.

At every contact it also records the size of the eps term of Eq. 23 relative to the contact
term, |eps sum_j c_j g_j A_i^e_j| / (f1 A_i^P) (= |F1(A_i, A_i, A_i)| / (f1 A_i^P), since the
contact terms cancel at equal amplitudes): the map assumes it is small.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from types import ModuleType
from typing import Mapping, Sequence

import numpy as np
from scipy.optimize import brentq

Array = np.ndarray


class MapIterationError(ValueError):
    """Bad arguments to the map iteration."""


@dataclass(frozen=True)
class MapRun:
    """Amplitudes A_i (and peaks A_i S(0), Eq. 32) of the contacts the map reached."""

    contacts: Array  # contacts with a value (first..stopped)
    A: Array
    peaks: Array
    status: str  # "ok", "died" (A below death_fraction of its seed), "no root" (Eq. 23 unsolvable)
    message: str
    variant: str
    profile: str
    seed_A: float
    seed_contact: int
    fallbacks: int  # steps where Newton failed and bracketing was used
    forcing_ratio: Array = dataclasses.field(default_factory=lambda: np.zeros(0))  # per contact, see module doc
    engine: str = "python"  # "compiled" (map_kernel.py) or "python" (the reference Newton)

    @property
    def max_forcing_ratio(self) -> float | None:
        """The largest relative size of the eps term over the contacts reached (None: none reached)."""
        return float(np.max(self.forcing_ratio)) if self.forcing_ratio.size else None


def forcing_ratio(module: ModuleType, a_i: float, eps: float, args: tuple) -> float:
    """|eps term| / contact term of Eq. 23 at amplitude a_i: |F1(a_i, a_i, a_i)| / (f1 a_i^P)."""
    amps = (a_i, a_i) if module.VARIANT == "1d" else (a_i, a_i, a_i)
    F1 = module.map_residual(*amps, eps, *args)[0]
    return abs(float(F1)) / (float(module.f1) * a_i ** float(module.P))


def eps0_ratio(module: ModuleType, args: tuple) -> float | None:
    """A_i / A_{i-1} of one step of Eq. 23 at eps = 0 (None if it has no root).

    At eps = 0 the map is homogeneous of degree P in the amplitudes, so every step scales A by
    this same factor: 1 for 'corrected' and '1d', (1 + f7/(2 f1))^(-1/P) for 'paper' (erratum 5, docs/errata.rst).
    """
    sol, _ = step(module, 1.0, 0.0, args)
    return None if sol is None else float(sol[0])


def contact_params(module: ModuleType, params: Mapping[str, object], contact: int) -> tuple:
    """The generated functions' parameter arguments (after eps) at contact ``contact``.

    ``params`` maps parameter names to a scalar or a per-bead array (bead k at index k - 1).
    """
    values = contact_params_table(module, params, np.array([contact]))
    return tuple(float(v) if np.ndim(v) == 0 else float(v[0]) for v in values)


def _newton(module, a_prev: float, guess: tuple[float, ...], eps: float, args: tuple) -> tuple[float, ...] | None:
    """Newton in log-amplitudes; None if it does not converge to positive amplitudes."""
    x = [math.log(g) for g in guess]
    two = len(guess) == 2
    for _ in range(60):
        amps = [math.exp(v) for v in x]
        try:
            res = module.map_residual(a_prev, *amps, eps, *args)
            jac, _ = module.map_jacobian(a_prev, *amps, eps, *args)
        except (OverflowError, ZeroDivisionError, ValueError):
            return None
        if two:
            (j11, j12), (j21, j22) = jac
            # chain rule to log variables
            j11, j21 = j11 * amps[0], j21 * amps[0]
            j12, j22 = j12 * amps[1], j22 * amps[1]
            det = j11 * j22 - j12 * j21
            if det == 0 or not math.isfinite(det):
                return None
            d0 = (res[0] * j22 - res[1] * j12) / det
            d1 = (res[1] * j11 - res[0] * j21) / det
            step = (d0, d1)
        else:
            j = jac[0][0] * amps[0]
            if j == 0 or not math.isfinite(j):
                return None
            step = (res[0] / j,)
        big = max(abs(s) for s in step)
        if not math.isfinite(big):
            return None
        damp = 1.0 if big < 0.5 else 0.5 / big
        x = [v - damp * s for v, s in zip(x, step)]
        if big < 1e-13:
            return tuple(math.exp(v) for v in x)
    return None


def _bracket_root(func, lo: float, hi: float, points: int = 400) -> float | None:
    """First sign change of func on a log grid in [lo, hi], refined by brentq."""
    grid = np.geomspace(lo, hi, points)
    prev = None
    for a, b in zip(grid[:-1], grid[1:]):
        fa = func(a) if prev is None else prev
        fb = func(b)
        prev = fb
        if math.isfinite(fa) and math.isfinite(fb) and fa * fb <= 0:
            return brentq(func, a, b, xtol=1e-15 * b, rtol=1e-15, maxiter=200)
    return None


def _fallback(module, a_prev: float, eps: float, args: tuple, two: bool) -> tuple[float, ...] | None:
    """Bracketing: A_{i+1}(A_i) from F2, then F1 in A_i; None when no positive root exists."""

    def next_of(a_i: float) -> float:
        root = _bracket_root(lambda c: module.map_residual(a_prev, a_i, c, eps, *args)[1], a_i * 1e-6, a_i * 1e3, 200)
        return math.nan if root is None else root

    def f1(a_i: float) -> float:
        if two:
            c = next_of(a_i)
            if not math.isfinite(c):
                return math.nan
            return module.map_residual(a_prev, a_i, c, eps, *args)[0]
        return module.map_residual(a_prev, a_i, eps, *args)[0]

    a_i = _bracket_root(f1, a_prev * 1e-9, a_prev * 1e2, 600)
    if a_i is None:
        return None
    return (a_i, next_of(a_i)) if two else (a_i,)


def step(module, a_prev: float, eps: float, args: tuple, guess: tuple[float, ...] | None = None):
    """One step of the map: (A_i, A_{i+1}) (or (A_i,)) and whether the fallback was used."""
    two = module.VARIANT != "1d"
    if guess is None:
        guess = (a_prev, a_prev) if two else (a_prev,)
    sol = _newton(module, a_prev, guess, eps, args)
    if sol is not None:
        return sol, False
    return _fallback(module, a_prev, eps, args, two), True


def check_seed(seed_A: float, error: type[ValueError], name: str = "the seed amplitude",
               seed_contact: int | None = None, last_contact: int | None = None) -> None:
    """Raise ``error`` unless ``seed_A`` is a finite number > 0 and ``last_contact`` (if given) comes
    after ``seed_contact``."""
    if not (isinstance(seed_A, (int, float)) and math.isfinite(seed_A) and seed_A > 0):
        raise error(f"{name} must be a finite number > 0, got {seed_A!r}")
    if seed_contact is not None and last_contact is not None and last_contact <= seed_contact:
        raise error(f"last contact {last_contact} must come after the seed contact {seed_contact}")


ENGINES = ("auto", "compiled", "python")


def has_power_table(module: ModuleType) -> bool:
    """Whether the generated module carries Eq. 23's power-term table (the compiled kernel's input)."""
    return hasattr(module, "map_power_coefficients")


def contact_params_table(module: ModuleType, params: Mapping[str, object], contacts: Array) -> tuple:
    """:func:`contact_params` for many contacts at once: a scalar per uniform parameter, an array
    (one value per contact) per site-dependent one and for ``i``."""
    contacts = np.asarray(contacts, dtype=int).reshape(-1)
    if contacts.size == 0:
        contacts = np.array([1])
    out = []
    for base, offset in module.ARGS:
        if base == "i":
            out.append(contacts.astype(float))
            continue
        if base not in params:
            raise MapIterationError(f"the map needs a value for parameter '{base}'")
        value = params[base]
        if np.ndim(value) == 0:
            out.append(float(value))
            continue
        arr = np.asarray(value, dtype=float)
        last = int(contacts.max()) + offset
        if last > arr.size:
            raise MapIterationError(
                f"parameter '{base}' has values for {arr.size} beads; contact {last - offset} needs bead {last}"
            )
        out.append(arr[contacts + offset - 1])
    return tuple(out)


def _coefficient_rows(module: ModuleType, args: tuple, rows: int) -> tuple[Array, Array]:
    """(K1, K2) of the power-term table as float arrays of shape (rows or 1, terms)."""
    k1, k2 = module.map_power_coefficients(*args)

    def stack(ks) -> Array:
        if not ks:
            return np.zeros((1, 0))
        cols = [np.broadcast_to(np.asarray(k, dtype=float), (rows,)) for k in ks]
        table = np.column_stack(cols)
        return table[:1] if all(np.ndim(k) == 0 for k in ks) else np.ascontiguousarray(table)

    return stack(k1), stack(k2)


#: "auto" compiles when the run is long enough to repay loading the kernel (a rule on the input only,
#: so that the same scene always gives the same numbers bit for bit).
AUTO_COMPILED_CONTACTS = 2000


def _engine(module: ModuleType, engine: str, contacts: int) -> str:
    if engine not in ENGINES:
        raise MapIterationError(f"unknown map engine {engine!r}: choose one of {', '.join(ENGINES)}")
    if engine == "python" or not has_power_table(module):
        if engine == "compiled":
            raise MapIterationError("this generated map module has no power-term table: regenerate it "
                                    "(delete it from the cache) to use the compiled engine")
        return "python"
    if engine == "auto" and contacts < AUTO_COMPILED_CONTACTS:
        return "python"
    return "compiled"


def iterate_map(
    module: ModuleType,
    seed_A: float,
    seed_contact: int,
    last_contact: int,
    eps: float,
    params: Mapping[str, object],
    death_fraction: float = 1e-6,
    engine: str = "auto",
) -> MapRun:
    """Iterate Eq. 23 from A_{seed_contact} = seed_A through contact ``last_contact``.

    ``engine``: "compiled" (the numba kernel of map_kernel.py on the module's power-term table;
    a contact where its Newton fails is finished by :func:`step`'s bracketing fallback),
    "python" (the reference: Newton on the generated residual and Jacobian) or "auto" (compiled
    when the module has the table and the run is long, >= AUTO_COMPILED_CONTACTS contacts). Both
    give the same amplitudes to 1e-10.
    """
    check_seed(seed_A, MapIterationError, "the map's seed amplitude", seed_contact, last_contact)
    if _engine(module, engine, last_contact - seed_contact) == "compiled":
        return _iterate_compiled(module, float(seed_A), seed_contact, last_contact, float(eps), params, death_fraction)
    return _iterate_python(module, float(seed_A), seed_contact, last_contact, float(eps), params, death_fraction)


def _no_root(i: int, a_prev: float, module: ModuleType, last_contact: int) -> str:
    return (
        f"no positive root of the map at contact {i} (A_{i - 1} = {a_prev:.6g}, peak "
        f"{a_prev * float(module.S0):.6g}): the reduction breaks down there; the map stops at contact {i - 1}"
    )


def _run(module: ModuleType, seed_A: float, seed_contact: int, contacts, amps, ratios, status: str, message: str,
         fallbacks: int, engine: str) -> MapRun:
    A = np.asarray(amps, dtype=float)
    return MapRun(
        contacts=np.asarray(contacts, dtype=int),
        A=A,
        peaks=A * module.S0,
        status=status,
        message=message,
        variant=module.VARIANT,
        profile=module.SOURCE["profile"],
        seed_A=float(seed_A),
        seed_contact=seed_contact,
        fallbacks=fallbacks,
        forcing_ratio=np.asarray(ratios, dtype=float),
        engine=engine,
    )


def _iterate_compiled(module: ModuleType, seed_A: float, seed_contact: int, last_contact: int, eps: float,
                      params: Mapping[str, object], death_fraction: float) -> MapRun:
    """The compiled kernel over all contacts; Python's bracketing fallback where Newton fails."""
    from pulsemap.solvers.models import map_kernel

    contacts = np.arange(seed_contact + 1, last_contact + 1)
    steps = contacts.size
    K1, K2 = _coefficient_rows(module, contact_params_table(module, params, contacts), steps)
    two = module.VARIANT != "1d"
    f1, f2, f3 = (float(getattr(module, k)) for k in ("f1", "f2", "f3"))
    P = float(module.P)
    p1 = np.asarray(module.MAP_POWERS1, dtype=float)
    p2 = np.asarray(module.MAP_POWERS2, dtype=float)
    A = np.empty(steps)
    ratio = np.empty(steps)
    a_min = death_fraction * seed_A
    pos, fallbacks = 0, 0
    a_prev, g0, g1 = seed_A, seed_A, seed_A
    status, message = "ok", f"reached contact {last_contact}"
    while pos < steps:
        r1 = K1[pos:] if K1.shape[0] > 1 else K1
        r2 = K2[pos:] if K2.shape[0] > 1 else K2
        done, code, g0, g1 = map_kernel.iterate_table(
            a_prev, g0, g1, steps - pos, two, P, f1, f2, f3, float(module.ALPHA), float(module.BETA), eps,
            p1, r1, p2, r2, a_min, A[pos:], ratio[pos:])
        pos += done
        if pos:
            a_prev = A[pos - 1]
        if code == 0:
            break
        i = int(contacts[pos])
        if code == 1:  # Newton failed: the reference step (Newton, then bracketing) finishes this contact
            args = contact_params(module, params, i)
            sol, _ = step(module, a_prev, eps, args, (g0, g1) if two else (g0,))
            fallbacks += 1
            if sol is not None and all(math.isfinite(x) and x > 0 for x in sol) and sol[0] >= a_min:
                A[pos] = sol[0]
                ratio[pos] = forcing_ratio(module, sol[0], eps, args)
                r = sol[0] / a_prev
                g0, g1 = sol[0] * r, (sol[1] if two else sol[0]) * r
                a_prev = sol[0]
                pos += 1
                continue
            code = 3 if sol is not None and all(math.isfinite(x) and x > 0 for x in sol) else 2
        if code == 3:
            status, message = "died", f"pulse died at contact {i}: A fell below {death_fraction:g} of its seed"
        else:
            status, message = "no root", _no_root(i, a_prev, module, last_contact)
        break
    return _run(module, seed_A, seed_contact, contacts[:pos], A[:pos], ratio[:pos], status, message, fallbacks,
                "compiled")


def _iterate_python(module: ModuleType, seed_A: float, seed_contact: int, last_contact: int, eps: float,
                    params: Mapping[str, object], death_fraction: float) -> MapRun:
    """The reference iteration: Newton on the generated residual and Jacobian, contact by contact."""
    contacts, amps, ratios = [], [], []
    a_prev = seed_A
    guess = None
    fallbacks = 0
    status, message = "ok", f"reached contact {last_contact}"
    for i in range(seed_contact + 1, last_contact + 1):
        args = contact_params(module, params, i)
        sol, used_fallback = step(module, a_prev, eps, args, guess)
        fallbacks += used_fallback
        if sol is None or not all(math.isfinite(s) and s > 0 for s in sol):
            status, message = "no root", _no_root(i, a_prev, module, last_contact)
            break
        a_i = sol[0]
        if a_i < death_fraction * seed_A:
            status = "died"
            message = f"pulse died at contact {i}: A fell below {death_fraction:g} of its seed"
            break
        contacts.append(i)
        amps.append(a_i)
        ratios.append(forcing_ratio(module, a_i, eps, args))
        ratio = a_i / a_prev
        guess = tuple(s * ratio for s in sol)
        a_prev = a_i
    return _run(module, seed_A, seed_contact, contacts, amps, ratios, status, message, fallbacks, "python")


def iterate_map_many(
    module: ModuleType,
    seed_A: Array,
    seed_contact: int,
    last_contact: int,
    eps: Array | float,
    params: Sequence[Mapping[str, object]],
    death_fraction: float = 1e-6,
) -> list[MapRun]:
    """Eq. 23 for many chains in one compiled call (threads over chains): chain c starts from
    seed_A[c] with eps[c] and params[c]. A chain whose Newton fails somewhere is redone by
    :func:`iterate_map` (which finishes such contacts with the bracketing fallback), so every
    MapRun equals the single-chain one."""
    from pulsemap.solvers.models import map_kernel

    if not has_power_table(module):
        raise MapIterationError("this generated map module has no power-term table: regenerate it")
    seeds = np.asarray(seed_A, dtype=float).ravel()
    chains = seeds.size
    for a in seeds:
        check_seed(float(a), MapIterationError, "every seed amplitude", seed_contact, last_contact)
    eps_arr = np.broadcast_to(np.asarray(eps, dtype=float), (chains,)).copy()
    if len(params) != chains:
        raise MapIterationError(f"params has {len(params)} entries for {chains} seed amplitudes: give one per chain")
    contacts = np.arange(seed_contact + 1, last_contact + 1)
    steps = contacts.size
    K1, K2 = _coefficient_tables(module, params, contacts)
    A = np.empty((chains, steps))
    ratio = np.empty((chains, steps))
    done = np.zeros(chains, dtype=np.int64)
    status = np.zeros(chains, dtype=np.int64)
    f1, f2, f3 = (float(getattr(module, k)) for k in ("f1", "f2", "f3"))
    map_kernel.iterate_table_batch(seeds, steps, module.VARIANT != "1d", float(module.P), f1, f2, f3,
                                   float(module.ALPHA), float(module.BETA), eps_arr,
                                   np.asarray(module.MAP_POWERS1, dtype=float), K1,
                                   np.asarray(module.MAP_POWERS2, dtype=float), K2, death_fraction, A, ratio,
                                   done, status)
    out = []
    for c in range(chains):
        k = int(done[c])
        if status[c] == 1:  # Newton failed at a contact: the single-chain path finishes it by bracketing
            out.append(iterate_map(module, seeds[c], seed_contact, last_contact, eps_arr[c], params[c], death_fraction))
            continue
        if status[c] == 0:
            state, message = "ok", f"reached contact {last_contact}"
        elif status[c] == 3:
            state, message = "died", f"pulse died at contact {contacts[k]}: A fell below {death_fraction:g} of its seed"
        else:
            state, message = "no root", _no_root(int(contacts[k]), A[c, k - 1] if k else seeds[c], module, last_contact)
        out.append(_run(module, seeds[c], seed_contact, contacts[:k], A[c, :k], ratio[c, :k], state, message, 0,
                        "compiled"))
    return out


def _coefficient_tables(module: ModuleType, params: Sequence[Mapping[str, object]], contacts: Array) -> tuple[Array, Array]:
    """K1, K2 of shape (chains, contacts or 1, terms): one vectorised call of the generated
    coefficients when every chain's parameters are uniform, else one call per chain."""
    per_chain = [contact_params_table(module, p, contacts) for p in params]
    if all(np.ndim(v) == 0 for args in per_chain for v in args):
        columns = tuple(np.array([args[k] for args in per_chain], dtype=float) for k in range(len(module.ARGS)))
        k1, k2 = module.map_power_coefficients(*columns)
        chains = len(params)

        def table(ks) -> Array:
            cols = [np.broadcast_to(np.asarray(k, dtype=float), (chains,)) for k in ks]
            return np.ascontiguousarray(np.stack(cols, axis=1)[:, None, :]) if cols else np.zeros((chains, 1, 0))

        return table(k1), table(k2)
    tables = [_coefficient_rows(module, args, contacts.size) for args in per_chain]
    rows = max(max(k1.shape[0], k2.shape[0]) for k1, k2 in tables)
    K1 = np.stack([np.broadcast_to(k1, (rows, k1.shape[1])) for k1, _ in tables])
    K2 = np.stack([np.broadcast_to(k2, (rows, k2.shape[1])) for _, k2 in tables])
    return np.ascontiguousarray(K1), np.ascontiguousarray(K2)
