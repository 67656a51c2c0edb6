"""The compiled engine of the map (Eq. 23): the generated module's power-term table fed to the
numba kernel of map_kernel.py, one chain or many; a contact where the kernel's Newton fails is
finished by the reference step (map_step.step, Newton then bracketing)."""

from __future__ import annotations

import math
from types import ModuleType
from typing import Mapping

import numpy as np

from pulsemap.solvers.models.map_step import (Array, MapRun, contact_params, contact_params_table, forcing_ratio,
                                              map_run, no_root_message, step)

def has_power_table(module: ModuleType) -> bool:
    """Whether the generated module carries Eq. 23's power-term table (the compiled kernel's input)."""
    return hasattr(module, "map_power_coefficients")


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


def iterate_compiled(module: ModuleType, seed_A: float, seed_contact: int, last_contact: int, eps: float,
                     params: Mapping[str, object], death_fraction: float) -> MapRun:
    """The map (Eq. 23) iterated by the compiled kernel over all contacts; Python's bracketing fallback
    where Newton fails (map_iteration.iterate_map's 'compiled' engine)."""
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
            status, message = "no root", no_root_message(i, a_prev, module, last_contact)
        break
    return map_run(module, seed_A, seed_contact, contacts[:pos], A[:pos], ratio[:pos], status, message, fallbacks,
                "compiled")
