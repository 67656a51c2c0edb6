"""The [perturbation] table of a scene: R, eps and the parameter forms (make_perturbation's errors as scene problems).

``pulsemap.symbolic.perturbation`` pulls in sympy, so it is imported inside the functions.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING, Any, Mapping

from pulsemap.solvers.data.scene_schema import _number, _Problem, _type_name

if TYPE_CHECKING:  # pragma: no cover
    from pulsemap.symbolic.perturbation import Perturbation


def _build_perturbation(table: Mapping[str, Any], name: str, drop_unused: bool = False) -> "Perturbation":
    """make_perturbation(R, eps, params), its errors as one-line problems.

    Every parameter given must occur in R (check_all_used); ``drop_unused`` instead drops the
    ones R does not use (with_overrides(R=...) keeping the old parameters).
    """
    from pulsemap.symbolic.expression import ExpressionError
    from pulsemap.symbolic.perturbation import PerturbationError, check_all_used, make_perturbation

    R = table["R"]
    if not isinstance(R, str):
        raise _Problem(f"[perturbation] R must be a string formula in u, v, i and parameters, got {_type_name(R)}: e.g. R = \"-mu*v\"")
    eps = _number(table["eps"], "[perturbation] eps")
    params = table.get("params") or {}
    if not isinstance(params, Mapping):
        raise _Problem(f"[perturbation] params must be a table of NAME = VALUE, got {_type_name(params)}")
    try:
        pert = make_perturbation(R, eps, dict(params))
        if drop_unused and pert.unused_parameters:
            used = {key: value for key, value in params.items() if key not in pert.unused_parameters}
            pert = make_perturbation(R, eps, used)
        return check_all_used(pert)
    except (PerturbationError, ExpressionError) as exc:
        raise _Problem("[perturbation] " + _scene_hint(str(exc))) from None


def _check_perturbation_object(value: Any) -> "Perturbation":
    from pulsemap.symbolic.perturbation import Perturbation

    if not isinstance(value, Perturbation):
        raise _Problem(f"perturbation must be a pulsemap.symbolic.perturbation.Perturbation, got {_type_name(value)}: or pass R, eps, params")
    return value


def _scene_hint(message: str) -> str:
    """Rewrite command-line advice for a scene file; keep the message on one line."""
    message = re.sub(r"--param (\w+)=VALUE", r"\1 = VALUE under [perturbation.params]", message)
    return " ".join(message.split())
