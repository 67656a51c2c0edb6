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

This module is the front: ``iterate_map`` picks the engine, the reference Newton
(map_step.py) or the compiled kernel (map_compiled.py).
"""

from __future__ import annotations

import math
from types import ModuleType
from typing import Mapping

from pulsemap.solvers.models.map_compiled import has_power_table, iterate_compiled
from pulsemap.solvers.models.map_step import (  # noqa: F401  (re-exported: the map's public names)
    Array, MapIterationError, MapRun, check_seed, contact_params, contact_params_table, eps0_ratio, forcing_ratio, map_run,
    no_root_message, step)

ENGINES = ("auto", "compiled", "python")


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
        return iterate_compiled(module, float(seed_A), seed_contact, last_contact, float(eps), params, death_fraction)
    return _iterate_python(module, float(seed_A), seed_contact, last_contact, float(eps), params, death_fraction)


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
            status, message = "no root", no_root_message(i, a_prev, module, last_contact)
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
    return map_run(module, seed_A, seed_contact, contacts, amps, ratios, status, message, fallbacks, "python")
