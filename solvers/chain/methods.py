"""The DNS methods of paper Eq. 1: one frozen record each, the one table every part reads.

``plan()`` (which engine and kernel), the compiled kernels' loading and ahead-of-time build list, the scipy
solver factory, the scene schema's ``[dns] method`` choices, the command line's ``--method`` choices and the
tests all read :data:`METHODS`; a new method is its kernel module (compiled) or scipy's class (scipy) plus one row.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

#: What every method accepts, checked where input enters (the scene file, ``Integrator``, ``simulate``).
MAX_BEADS = 1_000_000
"""Longest chain a scene or ``simulate`` takes."""
MIN_RTOL = 100 * sys.float_info.epsilon
"""Smallest rtol float64 can deliver (scipy raises a smaller one to this silently)."""
MAX_RTOL = 1.0
"""rtol at or above this accepts a 100 % error: no digit of a peak is kept."""
MIN_ATOL = 1e-150
"""Smallest atol: every engine's error norm squares error/atol, which overflows below ~1.5e-154 (the square root
of the smallest normal float64)."""


@dataclass(frozen=True)
class DNSMethod:
    """A way to integrate Eq. 1: ``name`` (scipy's where scipy has it), ``kernel`` (the module in solvers/chain
    of its compiled kernel, whose ``run`` integrates; "" none), ``scipy`` (scipy.integrate has a solver of that
    name), ``implicit`` (stiff: it solves with the Jacobian), ``order`` of the step, ``title``, and ``auto``: the
    roles in which 'auto' takes it (:data:`AUTO_ROLES`)."""

    name: str
    kernel: str
    scipy: bool
    implicit: bool
    order: int
    title: str
    auto: tuple[str, ...] = ()


METHODS: tuple[DNSMethod, ...] = (
    DNSMethod("DOP853", "compiled_dop853", True, False, 8, "explicit Runge-Kutta 8(5,3)", auto=("scipy explicit",)),
    DNSMethod("RK45", "compiled_kernel", True, False, 5, "Dormand-Prince 5(4)", auto=("explicit",)),
    DNSMethod("RK23", "", True, False, 3, "Bogacki-Shampine 3(2)"),
    DNSMethod("Radau", "", True, True, 5, "implicit Runge-Kutta (Radau IIA)"),
    DNSMethod("BDF", "", True, True, 5, "backward differentiation formulas", auto=("scipy ramp",)),
    DNSMethod("LSODA", "", True, True, 12, "Adams/BDF switching (ODEPACK)", auto=("scipy stiff",)),
    DNSMethod("Rodas4", "compiled_stiff", False, True, 4, "Rosenbrock", auto=("stiff",)),
)
AUTO = "auto"  # plan() chooses (chain/plan.py)
#: The force forms each compiled kernel is built for (chain/compiled_aot.COEF_TYPES): the dense cubics, the table.
FORMS = ("dense", "table")
#: What 'auto' chooses between: on the compiled engine a force that is not stiff / is; on the scipy engine the
#: same, and a stiff force with a ramp (a non-smooth R: chain/equations.choose_method says why).
AUTO_ROLES = ("explicit", "stiff", "scipy explicit", "scipy stiff", "scipy ramp")


def by_name(name: str) -> DNSMethod:
    """The record of method ``name`` (KeyError when there is none)."""
    for method in METHODS:
        if method.name == name:
            return method
    raise KeyError(name)


def auto_pick(role: str) -> str:
    """The method 'auto' takes in ``role`` (one of AUTO_ROLES): the one table row that names it."""
    assert role in AUTO_ROLES, role
    (name,) = (m.name for m in METHODS if role in m.auto)
    return name


def names(*, kernel: bool | None = None, scipy: bool | None = None, implicit: bool | None = None) -> tuple[str, ...]:
    """The methods' names in table order, those with a compiled kernel (``kernel``), a scipy solver (``scipy``),
    implicit or explicit (``implicit``) as asked (None: either)."""
    return tuple(m.name for m in METHODS
                 if (kernel is None or bool(m.kernel) == kernel) and (scipy is None or m.scipy == scipy)
                 and (implicit is None or m.implicit == implicit))


def selectable() -> tuple[str, ...]:
    """What Integrator(method=...) and a scene's [dns] method take: 'auto', every scipy method and every explicit
    compiled kernel (an implicit kernel runs when 'auto' finds the force stiff: chain/plan.py)."""
    return (AUTO,) + tuple(dict.fromkeys(names(scipy=True) + names(kernel=True, implicit=False)))


def kernels() -> dict[str, str]:
    """Compiled kernel module of every method that has one: name -> module (chain/compiled_aot.py builds them)."""
    return {m.name: m.kernel for m in METHODS if m.kernel}
