"""``pulsemap.dressed``: the dressed (second-order) amplitude law of eps R(u, v) (solvers/studies/dressed.py)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Mapping

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.api.checks import api_hint, merged_params, number

if TYPE_CHECKING:  # pragma: no cover - the dressed law loads sympy and scipy when it is derived
    from pulsemap.solvers.studies.dressed import DressedDerivation

__all__ = ["dressed"]


def dressed(
    R: str,
    *,
    eps: float = 0.1,
    n: float = 1.5,
    A0: float | None = None,
    i0: float = 0.0,
    params: Mapping[str, Any] | None = None,
    coefficients: str = "derived",
    **parameters: Any,
) -> DressedDerivation:
    """The dressed law d ln A/di = -sum k1 x/(1 - (k2/k1) x) - sum k2_jl x_j x_l of a uniform polynomial R.

    k1 is derived (energy balance); k2/k1, the onset lag and the cross terms are derived by expanding Eq. 1 to
    second order about the exact wave (``coefficients="derived"``, default) or calibrated on DNS decrements of
    launched solitons (``"calibrated"``; also the fallback); both cached, the paper's monomials ship
    precomputed. ``str()`` of the
    result is the report of ``pulsemap derive --model dressed``, ``.to_dict()`` its JSON, ``.law`` the
    law (``.law.terms``, ``.law.cross``, ``.law.rate_value(A)``, ``.law.validity()``).

    >>> d = dressed("-mu*v", mu=1, eps=0.1)  # doctest: +SKIP
    >>> d.law.terms[0].rho  # doctest: +SKIP
    0.2897...

    Raises TypeError or ValueError naming the argument for bad input.
    """
    from pulsemap.symbolic.dressed import DressedError
    from pulsemap.symbolic.expression import ExpressionError
    from pulsemap.symbolic.perturbation import PerturbationError, check_all_used, make_perturbation
    from pulsemap.symbolic.profile import ProfileError
    from pulsemap.solvers.studies.dressed import derive_dressed

    if not isinstance(R, str):
        raise TypeError(f"R must be a string formula in u, v and parameters (e.g. '-mu*v'), got {type(R).__name__}")
    eps, n = number(eps, "eps"), number(n, "n")
    A0 = None if A0 is None else number(A0, "A0")
    i0 = number(i0, "i0")
    if coefficients not in ("derived", "calibrated"):
        raise PulsemapError(f"coefficients must be 'derived' or 'calibrated', got {coefficients!r}")
    values = merged_params(params, parameters)
    try:
        pert = check_all_used(make_perturbation(R, eps, values))
        return derive_dressed(pert, n=n, A0_value=A0, i0=i0, source=coefficients)
    except (PerturbationError, ExpressionError, ProfileError, DressedError) as exc:
        raise PulsemapError(api_hint(str(exc))) from None
