"""Which engine, kernel, window and method a DNS run of paper Eq. 1 takes, and why: one pure function.

    x_i'' = (x_{i-1} - x_i)_+^n - (x_i - x_{i+1})_+^n + F_i(x_i, x_i')       (paper Eq. 1)

``plan`` reads what the caller asked for (engine, method, window) and what the force is (its
stiffness hint; whether the compiled kernels can take it, force_table.force_data) and returns a
``Plan``: the engine ("compiled": the numba kernels of chain/compiled.py; "scipy": chain/dns.py's
full chain or chain/window.py's moving window), the method or kernel, the window rule (None: the
full chain), the window engine of a scipy window (Hairer's Fortran codes or scipy's OdeSolver), and
the reason the result states (``DNSResult.engine_reason``). It integrates nothing.
"""

from __future__ import annotations

from dataclasses import dataclass

from pulsemap.solvers.chain.errors import DNSInputError
from pulsemap.solvers.chain import methods
from pulsemap.solvers.chain.equations import ENGINES, STIFFNESS_RATIO, choose_method
from pulsemap.solvers.chain.hairer import FORTRAN_CODES
from pulsemap.solvers.chain.peaks import contact_rate
from pulsemap.solvers.chain.window import WindowRule, WindowSpec, resolve_rule, window_accuracy_for

METHOD = methods.auto_pick("explicit")  # the default explicit kernel: 'auto' on a force that is not stiff (docs/dns.rst)
STIFF_METHOD = methods.auto_pick("stiff")  # the kernel 'auto' takes for a stiff force
#: Method 'auto' on the compiled engine runs Rodas4 when the force's stiffness hint exceeds this x the
#: contact rate: below it the explicit kernel is the cheaper at every rtol (docs/dns.rst).
COMPILED_STIFFNESS_RATIO = 300.0
WINDOW_ENGINES = ("auto", "fortran", "scipy")


@dataclass(frozen=True)
class Plan:
    """How a run goes: ``engine`` ("compiled" or "scipy"), ``method`` (the compiled kernel: RK45,
    DOP853, Rodas4; or the scipy method), ``rule`` (the moving window; None: the full chain),
    ``window_engine`` ("fortran" or "scipy" for a scipy window, "" otherwise) and ``reason``."""

    engine: str
    method: str
    rule: WindowRule | None
    window_engine: str
    reason: str


def unavailable(method: str, snapshots: bool = False) -> str:
    """Why the compiled engine cannot run this case ("" when it can; force_table.force_data says whether
    it can take the force)."""
    if snapshots:
        return "strain snapshots are recorded by the scipy engine only"
    if method != "auto" and method not in methods.names(kernel=True, implicit=False):
        shown = "; ".join(f"{m}, {methods.by_name(m).title}" for m in methods.names(kernel=True, implicit=False))
        return f"method {method} has no compiled kernel (compiled: {shown})"
    return ""


def wants_force_data(engine: str, method: str, snapshots: bool) -> bool:
    """Whether ``plan`` needs to know if the compiled kernels can take the force (the caller then asks
    force_table.force_data, which may generate and load code: only when it matters)."""
    return engine == "compiled" and not unavailable(method, snapshots)


def kernel_method(method: str, stiff: bool) -> str:
    """The compiled kernel for simulate's ``method``: the one named (RK45, DOP853), else ('auto')
    Rodas4 for a stiff force and Dormand-Prince 5(4) for any other."""
    if method in methods.names(kernel=True, implicit=False):
        return method
    return STIFF_METHOD if stiff else METHOD


def explicit_reason(method: str) -> str:
    """What an explicit kernel's result says ran."""
    title = methods.by_name(method).title
    if method == METHOD:
        return f"compiled {method} ({title})"
    return f"compiled {method} ({title}), method '{method}' requested"


def is_stiff(force, velocity: float, exponent: float) -> bool:
    """Method 'auto' on the compiled engine takes Rodas4: the force's stiffness hint (an OnSiteForce's or
    a MonomialTable's) exceeds COMPILED_STIFFNESS_RATIO x the contact rate."""
    return force is not None and force.stiffness_hint > COMPILED_STIFFNESS_RATIO * contact_rate(velocity, exponent)


def stiff_reason(force, velocity: float, exponent: float) -> str:
    """Why the Rosenbrock kernel (compiled_stiff.py) runs: the stiffness hint against the contact rate."""
    return (f"compiled Rosenbrock ({STIFF_METHOD}): stiffness hint {force.stiffness_hint:.4g} > "
            f"{COMPILED_STIFFNESS_RATIO:g} x contact rate {contact_rate(velocity, exponent):.4g}")


def auto_reason(force, velocity: float, exponent: float) -> str:
    """What an 'auto' run on the compiled engine says: Rodas4 and why, or Dormand-Prince 5(4), noting a
    force the scipy engine would call stiff (equations.STIFFNESS_RATIO) that this engine does not."""
    if is_stiff(force, velocity, exponent):
        return stiff_reason(force, velocity, exponent)
    rate = contact_rate(velocity, exponent)
    if force is not None and force.stiffness_hint > STIFFNESS_RATIO * rate:
        return (f"{explicit_reason(METHOD)}: stiffness hint {force.stiffness_hint:.4g} <= {COMPILED_STIFFNESS_RATIO:g} x "
                f"contact rate {rate:.4g}, where it is cheaper than {STIFF_METHOD}")
    return explicit_reason(METHOD)


def compiled_kernel(force, velocity: float, exponent: float, method: str) -> tuple[str, str]:
    """The compiled kernel for ``method`` and this force, and the reason its result gives."""
    auto = method == "auto"
    kernel = kernel_method(method, auto and is_stiff(force, velocity, exponent))
    return kernel, auto_reason(force, velocity, exponent) if auto else explicit_reason(kernel)


def plan(*, engine: str, method: str, force, velocity: float, exponent: float, rtol: float,
         window: "WindowSpec | int | str | WindowRule | None", snapshots: bool = False,
         force_reason: str = "", damping: float = 0.0, mass_step: float = 1.0) -> Plan:
    """The engine, kernel or method, window and reason of a run (module docstring).

    ``force``: anything with a ``stiffness_hint`` (an OnSiteForce, a MonomialTable) or None (R = 0);
    ``force_reason``: force_table.force_data's answer, "" when the compiled kernels can take the force
    (asked only where ``wants_force_data``); ``window``: as simulate() takes it (window.WindowSpec.of);
    ``damping``: the contact term's at the run's strain scale (contact_force.ContactTable.damping), which widens
    an 'auto' window (more at a larger ``exponent``; window.damped_behind); ``mass_step``: the largest ratio of
    neighbouring masses (window.largest_mass_step), above window.MASS_STEP_LIMIT an 'auto' window is the full chain.
    The compiled engine runs unless the caller asks for scipy, the method has no compiled kernel,
    snapshots are wanted or the force has no compiled form; the scipy engine's 'auto' is DOP853 or,
    for a stiff force, LSODA (equations.choose_method), on the Fortran codes where they apply.
    """
    if engine not in ENGINES:
        raise DNSInputError(f"unknown engine {engine!r}; choose one of {', '.join(ENGINES)}")
    spec = WindowSpec.of(window)
    rule = None if spec is None else resolve_rule(spec.size, window_accuracy_for(rtol, spec.accuracy), damping,
                                                  exponent, mass_step)
    why_scipy = "engine='scipy' requested"
    if engine == "compiled":
        why_scipy = unavailable(method, snapshots) or force_reason
        if not why_scipy:
            kernel, reason = compiled_kernel(force, velocity, exponent, method)
            return Plan("compiled", kernel, rule, "", reason)
    chosen = choose_method(force, velocity, exponent) if method == "auto" else method
    if rule is None:
        return Plan("scipy", chosen, None, "", why_scipy)
    if spec.engine not in WINDOW_ENGINES:
        raise DNSInputError(f"engine {spec.engine!r} cannot run method {chosen!r}; use engine='scipy'")
    resolved = ("fortran" if chosen in FORTRAN_CODES else "scipy") if spec.engine == "auto" else spec.engine
    if resolved == "fortran" and chosen not in FORTRAN_CODES:
        raise DNSInputError(f"engine {spec.engine!r} cannot run method {chosen!r}; use engine='scipy'")
    return Plan("scipy", chosen, rule, resolved, why_scipy)
