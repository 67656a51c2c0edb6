"""The Scene: a resolved, validated chain, excitation, perturbation and report request."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Mapping

from pulsemap.symbolic.frozenmap import FrozenMap
from pulsemap.symbolic.param_forms import param_data
from pulsemap.solvers.data.scene_checks import _check_consistency, _check_dns_table, _check_fields
from pulsemap.solvers.data.scene_params import _build_perturbation
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
        """A copy with some fields replaced, validated like a scene file.

        Keys are the field names; also ``R``, ``eps`` and ``params`` (raw values, as in a scene
        file) to rebuild the perturbation (a new ``R`` without ``params`` keeps the current
        parameters it uses and drops the others). ``dns`` is merged over the current DNS options.
        """
        fields = {f.name for f in dataclasses.fields(self)}
        allowed = sorted(fields | {"R", "eps", "params"})
        for key in kw:
            if key not in allowed:
                raise SceneError(_prefix(self.source, self.name) + _unknown(key, allowed, "in with_overrides()"))
        values = {name: getattr(self, name) for name in fields}
        try:
            raw = {key: value for key, value in kw.items() if key in fields}
            if "dns" in raw:
                raw["dns"] = _check_dns_table({**dict(self.dns), **_as_table(raw["dns"], "dns")})
            if {"R", "eps", "params"} & kw.keys():
                if "perturbation" in kw:
                    raise _Problem("give either perturbation or R/eps/params, not both")
                data = self.as_dict()["perturbation"]
                data.update({key: kw[key] for key in ("R", "eps", "params") if key in kw})
                raw["perturbation"] = _build_perturbation(data, self.name, drop_unused="params" not in kw)
            values.update(_check_fields(raw))
            scene = Scene(**values)
            _check_consistency(scene)
        except _Problem as exc:
            raise SceneError(_prefix(self.source, values.get("name", self.name)) + str(exc)) from None
        return scene
