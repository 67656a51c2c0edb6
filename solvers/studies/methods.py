"""The methods of a run: names, the thresholds of its warnings, and RunError (the models' titles and runners:
the model table, studies/run/models.py RUNNERS)."""

from __future__ import annotations

from dataclasses import dataclass

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.data.scene import METHODS

__all__ = ["BALANCE_METHODS", "MODELS", "Choice", "RunError"]

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


class RunError(PulsemapError):
    """A scene that cannot be run as asked."""


@dataclass(frozen=True)
class Choice:
    """Profile and map variant of a run (scene defaults unless overridden)."""

    profile: str
    variant: str
