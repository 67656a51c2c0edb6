"""What the steps of one run share (:class:`RunState`): the run, its models and its dressed law fill it in turn."""

from __future__ import annotations

from dataclasses import dataclass, field

from pulsemap.solvers.data.scene import Scene
from pulsemap.solvers.studies.methods import Choice

__all__ = ["RunState"]


@dataclass
class RunState:
    """What the steps of one run share: the scene and its choices, the seed so far, and the result."""

    scene: Scene
    methods: tuple[str, ...]
    choice: Choice
    out: dict
    given_seed: float | None = None  # a measured peak at first_perturbed - 1 (--seed-peak)
    seed_peak: float | None = None  # the DNS peak there, once known
    dns_peaks: list | None = None
    dns_alive: list | None = None
    contacts: list[int] = field(default_factory=list)
    snapshots: tuple[int, ...] = ()  # contacts at whose peak time the DNS keeps the strains around the pulse
    stated_accuracy: bool = True  # the relaxed map's leave-one-run-out accuracy (False: not computed, not reported)

    @property
    def timings(self) -> dict[str, float]:
        return self.out["timings_s"]

    @property
    def warnings(self) -> list[str]:
        return self.out["warnings"]
