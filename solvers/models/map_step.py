"""One contact of the amplitude map (Eq. 23) and the record of a run: the reference Newton.

At contact i, with A_{i-1} known, solve F1 = F2 = 0 for (A_i, A_{i+1}) (variants ``paper``,
``corrected``) or F1 = 0 for A_i (variant ``1d``): Newton's method in log-amplitudes with the
generated Jacobian; when it fails, a bracketing fallback (eliminate A_{i+1} from F2, then bisect F1
in A_i). Also the generated functions' parameter arguments per contact, the forcing ratio
|F1(A, A, A)| / (f1 A^P) and the MapRun every engine returns (map_iteration.py is the front).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from types import ModuleType
from typing import Mapping

import numpy as np

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.models.map_bracket import fallback

Array = np.ndarray


class MapIterationError(PulsemapError):
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


def step(module, a_prev: float, eps: float, args: tuple, guess: tuple[float, ...] | None = None):
    """One step of the map: (A_i, A_{i+1}) (or (A_i,)) and whether the fallback was used."""
    two = module.VARIANT != "1d"
    if guess is None:
        guess = (a_prev, a_prev) if two else (a_prev,)
    sol = _newton(module, a_prev, guess, eps, args)
    if sol is not None:
        return sol, False
    return fallback(module, a_prev, eps, args, two), True


def check_seed(seed_A: float, error: type[ValueError], name: str = "the seed amplitude",
               seed_contact: int | None = None, last_contact: int | None = None) -> None:
    """Raise ``error`` unless ``seed_A`` is a finite number > 0 and ``last_contact`` (if given) comes
    after ``seed_contact``."""
    if not (isinstance(seed_A, (int, float)) and math.isfinite(seed_A) and seed_A > 0):
        raise error(f"{name} must be a finite number > 0, got {seed_A!r}")
    if seed_contact is not None and last_contact is not None and last_contact <= seed_contact:
        raise error(f"last contact {last_contact} must come after the seed contact {seed_contact}")


def no_root_message(i: int, a_prev: float, module: ModuleType, last_contact: int) -> str:
    """Why the map (Eq. 23) stops at contact i - 1: no positive root A_i from A_{i-1} = ``a_prev``."""
    return (
        f"no positive root of the map at contact {i} (A_{i - 1} = {a_prev:.6g}, peak "
        f"{a_prev * float(module.S0):.6g}): the reduction breaks down there; the map stops at contact {i - 1}"
    )


def map_run(module: ModuleType, seed_A: float, seed_contact: int, contacts, amps, ratios, status: str, message: str,
            fallbacks: int, engine: str) -> MapRun:
    """The MapRun of amplitudes ``amps`` at ``contacts`` (peaks A_i S0), either engine's result."""
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
