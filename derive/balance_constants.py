"""The balance models' constants: the wave's energy and momentum (K1, V1, p1, D) and the profile
integrals w_ab (work) and j_ab (impulse) of the bead motion X(tau) = sum_{k>=0} S(tau - k), with
mpmath over the window |tau| <= L, cached on disk (derive/balance.py explains the models)."""

from __future__ import annotations

import math
from typing import Callable, Iterable

import mpmath

from .errors import PulsemapError
from .integrals import Constant, cached_constants, scalar_funcs
from .profile import check_exponent, exact_profile
from .sources import BALANCE_METHOD
from .sources import BALANCE_MODELS as MODELS

__all__ = ["WAVE_NAMES", "BalanceError", "balance_constants", "bead_motion", "check_model", "integral_name", "window"]

#: The wave's constants every model needs (E_1 = K1 + V1).
WAVE_NAMES = {"energy": ("K1", "V1"), "momentum": ("p1",)}


class BalanceError(PulsemapError):
    """A balance model that is undefined or cannot be built for this R (the message says why)."""


def check_model(model: str) -> str:
    """Return the balance model name, or raise a one-line error naming the known ones."""
    if model not in MODELS:
        raise BalanceError(f"unknown balance model {model!r}: choose one of {', '.join(MODELS)}")
    return model


def window(n: float) -> int:
    """Half-width L of the tau window: ceil(tail of the exact profile) + 1."""
    return int(math.ceil(exact_profile(check_exponent(n)).tail)) + 1


def integral_name(model: str, a: int, b: int) -> str:
    """w_ab (energy: int X^a X'^(b+1)) or j_ab (momentum: int X^a X'^b); '_' between digits past 9."""
    sep = "" if max(a, b) < 10 else "_"
    return ("w_" if model == "energy" else "j_") + f"{a}{sep}{b}"


def _parse_name(name: str) -> tuple[str, int, int]:
    if name in ("K1", "V1", "p1", "D"):
        return name, 0, 0
    if len(name) > 2 and name[:2] in ("w_", "j_"):
        body = name[2:]
        parts = body.split("_") if "_" in body else list(body)
        if len(parts) == 2 and all(p.isdigit() for p in parts):
            a, b = int(parts[0]), int(parts[1])
            if name[0] == "w" or b >= 1:
                return name[0], a, b
            raise BalanceError(f"{name} = int X^{a} dtau diverges (the bead ends displaced): impulse integrals need b >= 1")
    raise BalanceError(f"unknown balance integral {name!r}: use K1, V1, p1, D, w_ab or j_ab")


# ------------------------------------------------------------------------- constants
def bead_motion(S: Callable, dS: Callable, L: int) -> tuple[Callable, Callable]:
    """X(tau) = sum_{k>=0} S(tau - k) and X'(tau), with S truncated to |tau| <= L."""

    def terms(t, f):
        k0 = max(0, math.ceil(float(t) - L))
        k1 = math.floor(float(t) + L)
        return sum((f(t - k) for k in range(k0, k1 + 1)), mpmath.mpf(0))

    return (lambda t: terms(t, S)), (lambda t: terms(t, dS))


def _compute(profile, name: str, dps: int, L: int) -> tuple[float, float]:
    S, dS, _ = scalar_funcs(profile)
    X, dX = bead_motion(S, dS, L)
    n = mpmath.mpf(profile.n)
    kind, a, b = _parse_name(name)
    if kind == "K1":
        f = lambda t: dX(t) ** 2 / 2  # noqa: E731
    elif kind == "V1":
        f = lambda t: (S(t) ** (n + 1) / (n + 1)) if S(t) > 0 else mpmath.mpf(0)  # noqa: E731
    elif kind == "p1":
        f = dX
    elif kind == "D":
        f = S
    elif kind == "w":
        f = lambda t: X(t) ** a * dX(t) ** (b + 1)  # noqa: E731
    else:
        f = lambda t: X(t) ** a * dX(t) ** b  # noqa: E731
    with mpmath.workdps(dps):
        value, err = mpmath.quad(f, list(range(-L, L + 1)), error=True)
        value, err = float(value), float(err)
    if not math.isfinite(value):
        raise BalanceError(f"balance integral {name} did not converge (non-finite value)")
    return value, err


def _compute_bounded(prof, name: str, dps: int) -> tuple[float, float]:
    """The integral over |tau| <= L and its error bound: the exact profile is known to accuracy * S0
    pointwise, and the integrand sums 2L + 1 shifted copies of it."""
    L = window(prof.n)
    value, err = _compute(prof, name, dps, L)
    return value, abs(err) + ((2 * L + 1) * prof.accuracy * prof.S0 * max(1.0, abs(value)) if prof.kind == "exact" else 0.0)


def _cache_key(profile, dps: int, L: int) -> str:
    return f"balance-v{BALANCE_METHOD}|{profile.kind}|n={profile.n!r}|dps={dps}|L={L}"


def balance_constants(
    names: Iterable[str], *, n: float = 1.5, profile: str = "exact", dps: int | None = None, use_cache: bool = True,
    budget=None,
) -> dict[str, Constant]:
    """The wave constants (K1, V1, p1, D) and profile integrals (w_ab, j_ab) called ``names``.

    Computed on demand with mpmath and cached on disk, keyed by (n, profile, dps, window).
    """
    return cached_constants("balance", names, n=n, profile=profile, dps=dps, use_cache=use_cache,
                            key=lambda prof, dps: _cache_key(prof, dps, window(prof.n)),
                            check_name=_parse_name, compute=_compute_bounded, error=BalanceError, budget=budget)
