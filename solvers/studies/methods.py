"""The methods of a run: names, titles, the thresholds of its warnings, and RunError."""

from __future__ import annotations

from dataclasses import dataclass

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.data.scene import METHODS

__all__ = ["BALANCE_METHODS", "MODELS", "MODEL_TITLES", "Choice", "RunError"]

EPS_WARN = 0.3  # eps above this is outside the map's asymptotic assumption (eps << 1)
FORCING_WARN = 0.3  # eps term of Eq. 23 above this fraction of the contact term: same assumption, per contact
DRIFT_WARN = 0.05  # the 'paper' map's own drift at eps = 0 over the contacts run (erratum 5, docs/errata.rst)
WIDTH_WARN = 0.01  # f7/f1: the delta_{i+2} integral Eq. 9 drops, relative to the contact term f1

#: Every reduced model run_scene offers (all methods but the DNS), in canonical order.
MODELS: tuple[str, ...] = tuple(m for m in METHODS if m != "dns")
#: The balance models (derive/balance.py): method -> (balanced quantity, form).
BALANCE_METHODS = {
    "energy-map": ("energy", "map"),
    "energy-law": ("energy", "law"),
    "momentum-map": ("momentum", "map"),
    "momentum-law": ("momentum", "law"),
}
#: What each model is, for outputs that name it.
MODEL_TITLES = {
    "map": "amplitude map (paper Eq. 23)",
    "longwave": "long-wave law (paper Eq. 30)",
    "energy-map": "energy-balance map: E_1 A_i^(n+1) = E_1 A_(i-1)^(n+1) + W(A_(i-1))",
    "energy-law": "energy-balance law: E_1 dA^(n+1)/di = W(A)",
    "momentum-map": "momentum-balance map: p_1 A_i^(1+s) = p_1 A_(i-1)^(1+s) + J(A_(i-1))",
    "momentum-law": "momentum-balance law: p_1 dA^(1+s)/di = J(A)",
    "relaxed": "relaxed transfer map P_(k+1) = F(P_k), built from short DNS runs of the same R, with the tabulated onset",
    "dressed-law": "dressed law: d ln A/di = -sum k1 x/(1 - (k2/k1) x) - sum k2_jl x_j x_l (k1, k2/k1, onset lag, cross terms derived)",
}


class RunError(PulsemapError):
    """A scene that cannot be run as asked."""


@dataclass(frozen=True)
class Choice:
    """Profile and map variant of a run (scene defaults unless overridden)."""

    profile: str
    variant: str
