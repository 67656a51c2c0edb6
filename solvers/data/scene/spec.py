"""The Scene: a resolved, validated chain, excitation, perturbation and report request."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Mapping

from pulsemap.symbolic.frozenmap import FrozenMap
from pulsemap.symbolic.param_forms import param_data
from pulsemap.solvers.data.scene.schema import DNS_DEFAULTS

if TYPE_CHECKING:  # pragma: no cover
    from pulsemap.symbolic.contact_law import ContactLaw, Masses
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
    contact: "ContactLaw | None" = None  # eps_c P_k(d, w) in the contact law (None: Hertz d^n alone)
    masses: "Masses | None" = None  # bead masses (None: all 1)

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
            **self.extra_tables(),
        }

    def extra_tables(self) -> dict:
        """The [contact] and [masses] tables, in a scene file's layout (only those the scene has)."""
        out: dict = {}
        if self.contact is not None:
            c = self.contact
            out["contact"] = {"P": c.text, "eps": c.eps, "first_perturbed": c.first_perturbed,
                              "params": {name: param_data(value) for name, value in c.params.items()}}
        if self.masses is not None:
            m = self.masses
            out["masses"] = {"m": m.data(), "first_perturbed": m.first_perturbed,
                             "params": {name: param_data(value) for name, value in m.params.items()}}
        return out
