"""Hairer's Fortran DOP853 and DOPRI5 (scipy.integrate.ode) driven step by step for the windowed DNS
of paper Eq. 1, with an exact re-step of the same scheme for the quintic dense output of a peak."""

from __future__ import annotations

import warnings

import numpy as np

from pulsemap.solvers.chain.equations import ForceNotFinite, IntegratorFailed
from pulsemap.solvers.chain.peaks import QuinticStep

Array = np.ndarray

FORTRAN_CODES = {"DOP853": "dop853", "RK45": "dopri5"}  # Hairer's codes behind scipy.integrate.ode
FORTRAN_METHODS = {code: method for method, code in FORTRAN_CODES.items()}
# PI step-size control (Hairer's BETA): fewer rejected steps at contact openings (docs/dns.rst).
FORTRAN_BETA = {"dop853": 0.06, "dopri5": 0.04}


def tableau(method: str) -> tuple[Array, Array, Array]:
    """Butcher tableau (A, b, c) of the explicit scheme behind ``method`` (DOP853 or RK45)."""
    if method == "DOP853":
        from scipy.integrate._ivp import dop853_coefficients as co

        s = co.N_STAGES
        return co.A[:s, :s], co.B, co.C[:s]
    import scipy.integrate as _integrate  # scipy loads only when a scipy engine runs

    cls = getattr(_integrate, method)
    return cls.A, cls.B, cls.C


def exact_stepper(rhs, method: str):
    """``step(t, y, f, h) -> y(t + h)``: one step of ``method``'s own scheme (h may be < 0).

    Used by QuinticStep to read a peak's value at a located time: a step at most half as long
    as an accepted one has a smaller local error (order 8 for DOP853, 5 for RK45).
    """
    A, B, C = tableau(method)
    stages = len(B)

    def step(t: float, y: Array, f: Array, h: float) -> Array:
        K = np.empty((stages, len(y)))
        K[0] = f
        for j in range(1, stages):
            K[j] = rhs(t + C[j] * h, y + h * (A[j, :j] @ K[:j]))
        return y + h * (B @ K)

    return step


def run_fortran(code, rhs, t0, y0, t_max, rtol, atol, first_step, on_step) -> tuple[float, Array, int, float]:
    """Integrate with Hairer's DOP853/DOPRI5 (scipy.integrate.ode) until on_step says stop.

    ``on_step(t_old, y_old, t_new, y_new, dense_factory) -> bool`` is called after every
    accepted step; True interrupts the integration. Returns (t, y, nfev, last step size).
    """
    state = {"t": t0, "y": np.array(y0, float), "h": first_step or 0.0, "extra": 0}

    def counted(t: float, y: Array) -> Array:  # evaluations outside the Fortran loop
        state["extra"] += 1
        return rhs(t, y)

    step_exactly = exact_stepper(counted, FORTRAN_METHODS[code])

    def solout(t: float, y: Array) -> int:
        if t == state["t"]:
            return 0  # the initial point
        t_old, y_old = state["t"], state["y"]
        y_new = np.array(y)

        def dense_factory():
            return QuinticStep(t_old, y_old, counted(t_old, y_old), t, y_new, counted(t, y_new), step_exactly)

        state["h"] = t - t_old
        state["t"], state["y"] = t, y_new
        return -1 if on_step(t_old, y_old, t, y_new, dense_factory) else 0

    import scipy.integrate as _integrate

    failed: list[ForceNotFinite] = []

    def guarded(t: float, y: Array) -> Array:  # f2py would print an exception raised inside Fortran: kept
        try:
            return rhs(t, y)
        except ForceNotFinite as exc:
            failed.append(exc)
            return np.full(np.shape(y), np.nan)  # the Fortran code shrinks its step until it gives up

    r = _integrate.ode(guarded).set_integrator(code, rtol=rtol, atol=atol, nsteps=2**31 - 1,
                                               first_step=min(first_step or 0.0, t_max - t0),
                                               beta=FORTRAN_BETA[code])
    r.set_solout(solout)
    r.set_initial_value(y0, t0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r.integrate(t_max)
    if failed:
        raise failed[0]
    nfev = int(r._integrator.iwork[16]) + state["extra"]  # IWORK(17) = NFCN (Hairer)
    if not r.successful() and r.get_return_code() != 2 and state["t"] < t_max:
        said = "; ".join(str(w.message) for w in caught)  # scipy's warning says why: part of the stop reason
        raise IntegratorFailed(f"integrator failed at t={state['t']:.6g} (code {r.get_return_code()}"
                               f"{': ' + said if said else ''})", state["y"])
    for w in caught:  # scipy's own warnings of a run that went on
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return state["t"], state["y"], nfev, state["h"]
