"""The kinds of perturbation a scene states, one row each (:data:`KINDS`): the on-site force eps R_i (paper
Eq. 1), the contact law's term eps_c P(d, w) and the bead masses m_i.

A row says how a scene holds the kind, which reduced models are derived for it and which studies build their
chains with it. A scene may state several kinds at once: a model runs only where every kind the scene states
has it, and a study only where every kind takes it. A new kind is its scene table, its part of the chain
(models/chain_build.ChainSpec), its models' module and one row here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from pulsemap.solvers.data.scene import Scene
from pulsemap.solvers.studies.methods import MODELS, RunError

__all__ = ["KINDS", "PerturbationKind", "given", "refusals", "require"]

#: The models derived from the chain's energy (the contact law's work and the masses' wave speed) and the
#: relaxed map: what a contact-law term or masses run (studies/run/chain_terms.py, models/relaxed.py).
ENERGY_MODELS = frozenset({"energy-law", "energy-map", "relaxed"})


@dataclass(frozen=True)
class PerturbationKind:
    """A kind of perturbation: ``name`` (as messages say it), the scene file's ``table``, ``stated`` (does the
    scene hold it: R with a nonzero eps, a [contact] or a [masses] table), the reduced ``models`` derived for it
    and the ``studies`` that build chains with it (besides run, table and scene sweeps, which take every kind)."""

    name: str
    table: str
    stated: Callable[[Scene], bool]
    models: frozenset[str]
    studies: frozenset[str]


KINDS: tuple[PerturbationKind, ...] = (
    PerturbationKind("an on-site R", "perturbation",
                     lambda s: s.perturbation.acts,
                     frozenset(MODELS), frozenset({"bench", "ensemble", "bifurcation", "sweep tasks"})),
    PerturbationKind("a contact-law term P", "contact", lambda s: s.contact is not None, ENERGY_MODELS,
                     frozenset({"bench", "ensemble"})),
    PerturbationKind("bead masses", "masses", lambda s: s.masses is not None, ENERGY_MODELS,
                     frozenset({"bench", "ensemble"})),
)


def given(scene: Scene) -> tuple[PerturbationKind, ...]:
    """The kinds the scene states, in table order."""
    return tuple(kind for kind in KINDS if kind.stated(scene))


def refusals(scene: Scene, methods) -> dict[str, str]:
    """The reduced models asked for that some kind the scene states has none of, with why and what runs it."""
    kinds = given(scene)
    out = {}
    for m in methods:
        lacking = [k.name for k in kinds if m in MODELS and m not in k.models]
        if lacking:
            runs = sorted(set.intersection(*(set(k.models) for k in kinds)))
            out[m] = (f"not derived for {' and '.join(lacking)}; this scene states "
                      f"{' and '.join(k.name for k in kinds)}: {', '.join(runs + ['the DNS'])} run it")
    return out


def require(scene: Scene, study: str) -> None:
    """A one-line RunError where ``study`` builds its chains without a kind the scene states."""
    lacking = [k for k in given(scene) if study not in k.studies]
    if lacking:
        raise RunError(f"scene {scene.name} states {' and '.join(k.name for k in lacking)}: {study} builds its "
                       f"chains without {'it' if len(lacking) == 1 else 'them'} and does not take "
                       f"{'it' if len(lacking) == 1 else 'them'} yet; `pulsemap run`, `table` and scene sweeps "
                       "(`sweep --over`) do")
