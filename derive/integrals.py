"""Universal constants of the map: f1..f7 (Eqs. 17, 22) and g^(1)_klmq, g^(2)_pr (Eq. 23).

    f1 = int_{-inf}^0 S(t+1)^n dt      f2 = f5 = int_{-inf}^0 S(t)^n dt
    f3 = f6 = int_{-inf}^0 S(t-1)^n dt f4 = int_{-inf}^0 S''(t-1) dt  (= S'(-1))
    f7 = int_{-inf}^0 S(t-2)^n dt      (the delta_{i+2} term Eq. 22 drops; erratum 5, docs/errata.rst)
    g^(1)_klmq = int_{-inf}^0 S(t)^k S(t-1)^l S'(t)^m S'(t-1)^q dt
    g^(2)_pr   = int_{-inf}^0 S(t-1)^p S'(t-1)^r dt

Each is computed with ``mpmath.quad`` on unit sub-intervals at a stated working precision,
only when asked for, and cached on disk keyed by (n, profile, precision): a second run reads
them back. The exact profile is a float64 representation, so its constants carry the
profile's accuracy (see :class:`pulsemap.symbolic.profile.Profile`) on top of the quadrature error.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable, Iterable

import mpmath
import numpy as np

from .errors import PulsemapError
from . import cache
from .budget import Budget
from .profile import Profile, get_profile
from .sources import DEFAULT_DPS
from .sources import INTEGRALS_METHOD as METHOD_VERSION

F_NAMES = ("f1", "f2", "f3", "f4", "f5", "f6", "f7")


class IntegralError(PulsemapError):
    """Bad request for an integral (negative exponents, a divergent integral)."""


@dataclass(frozen=True)
class Constant:
    """A universal constant with its provenance."""

    name: str
    value: float
    error: float  # absolute error estimate (quadrature + profile accuracy)
    profile: str
    n: float
    dps: int

    def as_dict(self) -> dict:
        return {"value": self.value, "error": self.error}


def g1_name(k: int, l: int, m: int, q: int) -> str:
    """Canonical name of g^(1)_klmq (digits joined with underscores past 9)."""
    parts = (k, l, m, q)
    sep = "" if max(parts) < 10 else "_"
    return "g1_" + sep.join(str(p) for p in parts)


def g2_name(p: int, r: int) -> str:
    """Canonical name of g^(2)_pr."""
    sep = "" if max(p, r) < 10 else "_"
    return f"g2_{p}{sep}{r}"


def _check_exponents(exps: Iterable[int], what: str) -> tuple[int, ...]:
    out = []
    for e in exps:
        if isinstance(e, bool) or not isinstance(e, (int, np.integer)) or e < 0:
            raise IntegralError(
                f"{what} needs non-negative integer exponents, got {tuple(exps)!r}"
            )
        out.append(int(e))
    if sum(out) == 0:
        raise IntegralError(
            f"{what} with all exponents zero diverges (int_-inf^0 1 dt): "
            "a constant term of R must cancel (R(0, 0) = 0)"
        )
    return tuple(out)


# ------------------------------------------------------------------ scalar integrands
_MEMO_LIMIT = 2_000_000  # entries per function before its table is emptied (memory bound)
_FUNCS: dict[tuple[str, float], tuple[Callable, Callable, Callable]] = {}


def _memo(f: Callable) -> Callable:
    """``f`` remembering its values by (argument, working precision): mpmath.quad evaluates every
    integral of one profile at the same nodes, so a derivation with hundreds of integrals computes
    S, S', S'' there once (bit-identical values)."""
    table: dict = {}

    def memo(t):
        key = (getattr(t, "_mpf_", t), mpmath.mp.prec)  # the raw tuple hashes faster than an mpf
        value = table.get(key)
        if value is None:
            if len(table) > _MEMO_LIMIT:
                table.clear()
            value = table[key] = f(t)
        return value

    return memo


def scalar_funcs(profile: Profile) -> tuple[Callable, Callable, Callable]:
    """(S, S', S'') as functions of an mpf/float argument, in the profile's own arithmetic (memoized)."""
    key = (profile.kind, float(profile.n))
    if key not in _FUNCS:
        _FUNCS[key] = tuple(_memo(f) for f in _plain_funcs(profile))
    return _FUNCS[key]


def _plain_funcs(profile: Profile) -> tuple[Callable, Callable, Callable]:
    """(S, S', S'') as functions of an mpf/float argument, in the profile's own arithmetic."""
    if profile.kind == "pade":
        q0, q2, q4, q6, q8 = (mpmath.mpf(c) for c in profile.q)

        def poly(t):
            t2 = t * t
            return q0 + t2 * (q2 + t2 * (q4 + t2 * (q6 + t2 * q8)))

        def dpoly(t):
            t2 = t * t
            return t * (2 * q2 + t2 * (4 * q4 + t2 * (6 * q6 + t2 * 8 * q8)))

        def d2poly(t):
            t2 = t * t
            return 2 * q2 + t2 * (12 * q4 + t2 * (30 * q6 + t2 * 56 * q8))

        return (
            lambda t: poly(t) ** -2,
            lambda t: -2 * dpoly(t) * poly(t) ** -3,
            lambda t: 6 * dpoly(t) ** 2 * poly(t) ** -4 - 2 * d2poly(t) * poly(t) ** -3,
        )

    scalar = profile.scalar_evaluator()
    mpf = mpmath.mpf
    return (
        lambda t: mpf(scalar(float(t), 0)),
        lambda t: mpf(scalar(float(t), 1)),
        lambda t: mpf(scalar(float(t), 2)),
    )


def _intervals(profile: Profile, shift_min: int) -> list:
    """Break points for int_{-inf}^0 of a product whose slowest factor is S(t - shift_min)."""
    if profile.kind == "pade":
        lo = -8 - shift_min
        return [-mpmath.inf] + list(range(lo, 1))
    lo = -int(math.ceil(profile.tail)) - 1 + shift_min
    lo = min(lo, -1)
    return list(range(lo, 1))


def _quad(profile: Profile, integrand: Callable, shift_min: int, dps: int) -> tuple[float, float]:
    with mpmath.workdps(dps):
        value, err = mpmath.quad(integrand, _intervals(profile, shift_min), error=True)
        value = float(value)
        err = float(err)
    if not math.isfinite(value):
        raise IntegralError("integral did not converge (non-finite value)")
    return value, err


def _compute(profile: Profile, name: str, dps: int) -> tuple[float, float]:
    """Evaluate the integral called ``name`` (f1..f7, g1_klmq, g2_pr) for ``profile``."""
    S, dS, d2S = scalar_funcs(profile)
    n = mpmath.mpf(profile.n)
    pos = lambda x: x**n if x > 0 else mpmath.mpf(0)  # noqa: E731
    if name in F_NAMES:
        shift = {"f1": 1, "f2": 0, "f3": -1, "f4": -1, "f5": 0, "f6": -1, "f7": -2}[name]
        if name == "f4":
            return _quad(profile, lambda t: d2S(t + shift), 0, dps)
        return _quad(profile, lambda t: pos(S(t + shift)), min(shift, 0), dps)
    if name.startswith("g1_"):
        k, l, m, q = _parse_indices(name, 4)

        def g1(t):
            return S(t) ** k * S(t - 1) ** l * dS(t) ** m * dS(t - 1) ** q

        return _quad(profile, g1, 0 if (k or m) else -1, dps)
    if name.startswith("g2_"):
        p, r = _parse_indices(name, 2)
        return _quad(profile, lambda t: S(t - 1) ** p * dS(t - 1) ** r, -1, dps)
    raise IntegralError(f"unknown integral {name!r}: use f1..f7, g1_klmq or g2_pr")


def _parse_indices(name: str, count: int) -> tuple[int, ...]:
    body = name[3:]
    parts = body.split("_") if "_" in body else list(body)
    if len(parts) != count or not all(p.isdigit() for p in parts):
        raise IntegralError(f"malformed integral name {name!r}")
    return _check_exponents([int(p) for p in parts], name)


# ------------------------------------------------------------------------ public API
def _cache_key(profile: Profile, dps: int) -> str:
    return f"v{METHOD_VERSION}|{profile.kind}|n={profile.n!r}|dps={dps}"


def cached_constants(
    namespace: str,
    names: Iterable[str],
    *,
    n: float,
    profile: str,
    dps: int | None,
    use_cache: bool,
    key: Callable[[Profile, int], str],
    check_name: Callable[[str], object],
    compute: Callable[[Profile, str, int], tuple[float, float]],
    error: type[Exception],
    budget: "Budget | None" = None,
) -> dict[str, Constant]:
    """Constants ``names`` from the cache table ``key(profile, dps)`` in ``namespace``; the missing
    ones computed as (value, error bound) by ``compute`` and stored. Every name is checked by
    ``check_name`` before any work; a bad dps raises ``error``."""
    prof = get_profile(profile, n)
    dps = int(dps if dps is not None else DEFAULT_DPS[prof.kind])
    if dps < 10 or dps > 200:
        raise error(f"precision dps={dps} out of range: use 10 <= dps <= 200")
    wanted = list(dict.fromkeys(names))
    for name in wanted:
        check_name(name)
    table_key = key(prof, dps)
    table = _good_entries(cache.load(namespace, table_key), namespace, table_key) if use_cache else {}
    missing = [name for name in wanted if name not in table]
    done: list[str] = []
    saved = time.perf_counter()
    try:
        for k, name in enumerate(missing):
            if budget is not None:
                budget.step(f"{namespace} not yet cached (one quadrature each)", k, len(missing))
            table[name] = list(compute(prof, name, dps))
            done.append(name)
            if use_cache and time.perf_counter() - saved > 30.0:  # a long run keeps what it has
                _store(namespace, table_key, {x: table[x] for x in done})
                saved = time.perf_counter()
        if budget is not None and missing:
            budget.step(f"{namespace} not yet cached (one quadrature each)", len(missing), len(missing))
    finally:  # also when stopped by the time bound: the next run resumes
        if done and use_cache:
            _store(namespace, table_key, {x: table[x] for x in done})
    return {name: Constant(name, table[name][0], table[name][1], prof.kind, prof.n, dps) for name in wanted}


def _store(namespace: str, table_key: str, new: dict) -> None:
    """Merge ``new`` entries into the cached table (re-read first: another process may have added some)."""
    fresh = _good_entries(cache.load(namespace, table_key, quiet=True), namespace, table_key, quiet=True)
    fresh.update(new)
    cache.store(namespace, table_key, fresh)


def _good_entries(table: object, namespace: str, key: str, quiet: bool = False) -> dict:
    """The entries of a cached table that are [value, error bound] with both finite and the bound >= 0;
    the others are noted (once) as damaged and left out, so they are computed again."""
    if table is None:
        return {}
    if not isinstance(table, dict):
        if not quiet:
            cache.note_damaged(namespace, key, f"a {type(table).__name__}, not a table of constants")
        return {}
    good = {name: v for name, v in table.items()
            if isinstance(v, list) and len(v) == 2 and all(cache.finite_number(x) for x in v) and v[1] >= 0}
    bad = [name for name in table if name not in good]
    if bad and not quiet:
        cache.note_damaged(namespace, key, "bad values for " + ", ".join(map(str, bad[:4])) + (" ..." if len(bad) > 4 else ""))
    return good


def _check_name(name: str) -> None:
    if name not in F_NAMES:
        if name.startswith("g1_"):
            _parse_indices(name, 4)
        elif name.startswith("g2_"):
            _parse_indices(name, 2)
        else:
            raise IntegralError(f"unknown integral {name!r}: use f1..f7, g1_klmq or g2_pr")


def _compute_bounded(prof: Profile, name: str, dps: int) -> tuple[float, float]:
    """The integral and its error bound: the exact profile is known to accuracy * S0 pointwise."""
    value, err = _compute(prof, name, dps)
    return value, abs(err) + (prof.accuracy * prof.S0 * max(1.0, abs(value)) if prof.kind == "exact" else 0.0)


def constants(
    names: Iterable[str],
    *,
    n: float = 1.5,
    profile: str = "exact",
    dps: int | None = None,
    use_cache: bool = True,
    budget: "Budget | None" = None,
) -> dict[str, Constant]:
    """The universal constants called ``names``, computed on demand and cached on disk.

    Only the names asked for are computed; values already in the cache cost a file read.
    ``budget`` (derive/budget.py) bounds the time and reports progress.
    """
    return cached_constants("integrals", names, n=n, profile=profile, dps=dps, use_cache=use_cache, key=_cache_key,
                            check_name=_check_name, compute=_compute_bounded, error=IntegralError, budget=budget)


def g1(k: int, l: int, m: int, q: int, **kw) -> Constant:
    """g^(1)_klmq of Eq. 23 (see :func:`constants` for keyword arguments)."""
    _check_exponents((k, l, m, q), "g^(1)")
    name = g1_name(k, l, m, q)
    return constants([name], **kw)[name]


def g2(p: int, r: int, **kw) -> Constant:
    """g^(2)_pr of Eq. 23 (see :func:`constants` for keyword arguments)."""
    _check_exponents((p, r), "g^(2)")
    name = g2_name(p, r)
    return constants([name], **kw)[name]
