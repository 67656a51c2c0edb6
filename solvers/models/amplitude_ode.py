"""Integrate an amplitude law dB/di = rate(i, B), B = A^Q, along the chain (LSODA, rtol 1e-11).

Shared by the laws that have no closed form: the site-dependent laws (site_law_eval.py) and the
energy balance of a non-polynomial R (energy_quadrature.py). Events stop the law at extinction
(B -> 1e-12 B0) and blow-up (B -> 1e12 B0).
"""

from __future__ import annotations

from typing import Callable

import numpy as np


def integrate_amplitude_law(rate: Callable[[float, float], float], A0: float, Q: float, i0: float, contacts,
                            error: type[Exception], what: str) -> tuple[list, float | None, str]:
    """(A at ``contacts``, None past the law's end; contact index where it ended or None;
    "extinction", "blow-up" or "") from A(i0) = A0. A failed integration raises ``error``."""
    contacts = np.asarray(contacts, dtype=float)
    B0 = A0**Q

    def die(i, y):
        return y[0] - 1e-12 * B0

    def blow(i, y):
        return y[0] - 1e12 * B0

    die.terminal = blow.terminal = True
    end = max(float(contacts.max(initial=i0)), i0 + 1e-9)
    from scipy.integrate import solve_ivp  # scipy loads only when a law is evaluated

    sol = solve_ivp(lambda i, y: [rate(i, y[0])], (i0, end), [B0], method="LSODA", rtol=1e-11, atol=1e-14 * B0,
                    dense_output=True, events=(die, blow))
    if sol.status < 0:
        raise error(f"{what} could not be integrated: {sol.message}")
    ended_at, ended = None, ""
    if sol.status == 1:
        ended_at = float(sol.t[-1])
        ended = "extinction" if sol.t_events[0].size else "blow-up"
    stop = float(sol.t[-1])
    values = [max(float(sol.sol(c)[0]), 0.0) ** (1.0 / Q) if c <= stop + 1e-12 else None for c in contacts]
    return values, ended_at, ended
