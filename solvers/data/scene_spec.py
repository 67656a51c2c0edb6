"""The Scene: a resolved, validated chain, excitation, perturbation and report request."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Mapping

from pulsemap.symbolic.frozenmap import FrozenMap
from pulsemap.symbolic.param_forms import param_data
from pulsemap.solvers.data.scene_params import _check_perturbation_object
from pulsemap.solvers.data.scene_schema import DNS_DEFAULTS, SceneError, _as_table, _prefix, _Problem, _unknown

if TYPE_CHECKING:  # pragma: no cover
    from pulsemap.symbolic.perturbation import Perturbation


def _default_dns() -> FrozenMap:
    return FrozenMap(tuple(DNS_DEFAULTS.items()))


@dataclass(frozen=True)
class Scene:
    """A resolved, validated scene. Build it with :func:`load_scene` or :func:`parse_scene`."""

    name: str
    beads: int | None  # None: the chain is as long as the contacts need (the DNS picks it)
    exponent: float  # n
    first_perturbed: int  # bead where R starts (paper: 16)
    velocity: float  # v0 of bead 1
    perturbation: "Perturbation"  # R, eps, params (pulsemap.symbolic.perturbation)
    contacts: tuple[int, int]  # first and last contact reported (1-based, inclusive)
    methods: tuple[str, ...]  # subset of METHODS, in canonical order
    profile: str = "exact"  # "exact" | "pade"
    variant: str = "paper"  # "paper" | "corrected" | "1d"
    dns: Mapping[str, Any] = dataclasses.field(default_factory=_default_dns)
    source: str = ""  # path or "builtin:NAME"

    def as_dict(self) -> dict:
        """The scene as resolved, JSON-serialisable, in the layout of a scene file.

        R is its text, parameters are in their input form (numbers, per-bead lists, random
        draws as ``{"uniform": [lo, hi], "seed": s}``, expressions of i as text) and every
        default is filled in; ``beads`` is null when unset. ``parse_scene(d, source)`` of the
        result gives back an equal scene (``source`` in the dict is informational).
        """
        pert = self.perturbation
        return {
            "name": self.name,
            "source": self.source,
            "chain": {
                "beads": self.beads,
                "exponent": self.exponent,
                "first_perturbed": self.first_perturbed,
            },
            "excitation": {"velocity": self.velocity},
            "perturbation": {
                "R": pert.text,
                "eps": pert.eps,
                "params": {name: param_data(value) for name, value in pert.params.items()},
            },
            "output": {"contacts": list(self.contacts), "methods": list(self.methods)},
            "model": {"profile": self.profile, "variant": self.variant},
            "dns": dict(self.dns),
        }

    def with_overrides(self, **kw: Any) -> "Scene":
        """A copy with some fields replaced, validated like a scene file (data/overrides.apply_overrides).

        Keys are the field names; also ``R``, ``eps`` and ``params`` (raw values, as in a scene
        file) to rebuild the perturbation (a new ``R`` without ``params`` keeps the current
        parameters it uses and drops the others). ``dns`` is merged over the current DNS options.
        """
        from pulsemap.solvers.data.overrides import FIELD_KEYS, apply_overrides  # it rebuilds Scenes: imported here

        allowed = sorted(FIELD_KEYS.keys() | {"dns", "perturbation"})
        changes: list[tuple[str, Any]] = []
        try:
            for key, value in kw.items():
                if key not in allowed:
                    raise _Problem(_unknown(key, allowed, "in with_overrides()"))
                if key == "dns":
                    changes += [(f"dns.{k}", v) for k, v in _as_table(value, "dns").items()]
                elif key == "perturbation":
                    if {"R", "eps", "params"} & kw.keys():
                        raise _Problem("give either perturbation or R/eps/params, not both")
                    pert = _check_perturbation_object(value)
                    changes += [("perturbation.R", pert.text), ("perturbation.eps", pert.eps),
                                ("perturbation.params", {k: param_data(v) for k, v in pert.params.items()})]
                else:
                    changes.append((FIELD_KEYS[key], value))
        except _Problem as exc:
            raise SceneError(_prefix(self.source, self.name) + str(exc)) from None
        return apply_overrides(self, changes)
