"""``pulsemap.derive_contact``: from a contact-law term P(d, w) to its first-order energy law (derive/contact.py)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Mapping

if TYPE_CHECKING:  # pragma: no cover - sympy loads when a derivation is made, not on import
    import sympy

from pulsemap.solvers.api.checks import choice, merged_params, number
from pulsemap.solvers.api.derivation import PROFILES

__all__ = ["derive_contact"]


def derive_contact(
    P: str | sympy.Expr,
    *,
    eps: float = 0.1,
    n: float = 1.5,
    mass: float = 1.0,
    profile: str = "exact",
    params: Mapping[str, Any] | None = None,
    **parameters: Any,
) -> Any:
    """The first-order energy law of a contact-law term: F(d, w) = H(d) (d^n + eps P(d, w)), w = d' (docs/contact.rst).

    ``P`` is a sum of terms c d^a w^b (text, ``"gamma*d^(1/2)*w"``, or sympy in symbols d, w); ``mass`` the beads'.
    Returns a ``pulsemap.symbolic.contact.ContactDerivation``: ``law`` (the sympy ODE and, for one power, the
    closed-form A(k)), the constants I_ab and E_1, the elastic terms' entry jump and speed. A parameter given no
    value stays a symbol. Raises TypeError or ValueError naming the argument for bad input.

    >>> d = derive_contact("gamma*w", gamma=1, eps=0.02)
    >>> d.law.law  # doctest: +SKIP
    """
    import sympy

    from pulsemap.symbolic.contact import derive_contact as derive_law
    from pulsemap.symbolic.contact_law import make_contact_law

    eps = number(eps, "eps")
    n = number(n, "n")
    mass = number(mass, "mass")
    profile = choice(profile, "profile", PROFILES)
    if not isinstance(P, (str, sympy.Basic)):
        raise TypeError(f"P must be a formula in d, w (text or sympy), got {type(P).__name__}")
    values = merged_params(params, parameters)
    law = make_contact_law(P, eps, values, free=True)
    numbers = {name: float(value) for name, value in values.items() if isinstance(value, (int, float))
               and not isinstance(value, bool)}
    return derive_law(law.monomials, n=n, eps=eps, params=numbers, mass=mass, profile=profile)
