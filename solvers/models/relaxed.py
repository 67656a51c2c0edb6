"""The relaxed transfer map with its onset (issue 17): a reduced model built from the DNS itself.

In the bulk of a uniformly perturbed chain the primary pulse has no memory beyond its amplitude:
a few contacts after it enters the perturbed region its shape is slaved to its peak P, so the
peaks obey a one-dimensional map P_{k+1} = F(P_k) (the *relaxed map*). The pulse enters at
contact first_perturbed - 1 as the bare solitary wave, and for the next contacts it still
remembers that (it decays less than a relaxed pulse of the same amplitude): the *onset*.

The model (tables: solvers/models/relaxed_table.py):

* onset, contacts seed+1 .. seed+ONSET: the per-contact ratios of canonical segment runs (an
  exact solitary wave launched into the same perturbed chain, entering it bare) interpolated in
  their entry peak to the scene's seed peak. It assumes the scene's pulse enters as the formed
  solitary wave (true to ~1e-4 after the scenes' 15 unperturbed contacts) and that R is uniform
  over the onset; it is calibrated on the segment runs only, never on the scene it predicts.
* bulk, from contact seed+ONSET+1 on: the relaxed map F, a smoothing spline of log(P_{k+1}/P_k)
  against log P_k pooled over all segment runs after their onset.

Scaling (derive/scaling.py): for a single monomial eps c u^a v^b every ratio is a function of
x = eps c A^e only, so the tables are built once for R = +-u^a v^b at eps = 1 and used for any
eps, c and v0 by the amplitude change A' = |eps c|^(1/e) A; a site-dependent coefficient (graded
or random foundation) uses the map at the local coefficient of each contact's first bead.
Several monomials (or a non-polynomial R, or e = 0) get tables of their own R, eps and params;
site-dependent R with several monomials is refused. Below |x| = X_SMALL the log-ratios are
continued linearly in x (first order in the perturbation), which covers c = 0 exactly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from pulsemap.solvers.models.onsite import onsite_force
from pulsemap.solvers.models.relaxed_table import ONSET, SegmentSpec, SegmentTable, leave_one_out

X_SMALL = 1e-3  # |x| below which a monomial's log-ratios are continued linearly in x
TITLE = "relaxed transfer map (canonical segment runs) with the tabulated onset"


class RelaxedError(ValueError):
    """A perturbation or argument the relaxed map cannot take (and why)."""


@dataclass
class RelaxedModel:
    """Onset and bulk tables and how a scene's amplitudes map onto them.

    ``coefficients``: eps_i c_i per bead (1-based at index i-1) for the monomial path, None for
    a table of the scene's own R. ``e``: the monomial's scaling exponent. ``tables``: one per sign
    of the coefficient (monomial path) or {0: the scene's table}.
    """

    n: float
    spec: SegmentSpec
    tables: dict
    coefficients: np.ndarray | None = None
    e: float | None = None
    exponents: tuple[int, int] | None = None

    # ------------------------------------------------------------ amplitude change
    def _local(self, bead: int) -> tuple[int, float] | None:
        """(table sign, log lambda) at ``bead``; None when the coefficient there is 0."""
        if self.coefficients is None:
            return 0, 0.0
        c = float(self.coefficients[min(bead, len(self.coefficients)) - 1])
        if c == 0.0:
            return None
        return (1 if c > 0 else -1), math.log(abs(c)) / self.e

    def table(self, sign: int) -> SegmentTable:
        if sign not in self.tables:
            text = _monomial_text(*self.exponents, sign)
            self.tables[sign] = SegmentTable(SegmentSpec(text, (), 1.0, self.n, self.spec.rtol,
                                                         self.spec.window_accuracy))
        return self.tables[sign]

    def _small_side(self, log_p: float, table: SegmentTable) -> float | None:
        """log P' of the X_SMALL boundary when log_p lies beyond it (monomial path), else None."""
        if self.e is None:
            return None
        from pulsemap.symbolic.profile import exact_profile

        # |x| = (P'/S0)^e; X_SMALL boundary at log P' = log S0 + log(X_SMALL)/e
        bound = math.log(exact_profile(self.n).S0) + math.log(X_SMALL) / self.e
        beyond = log_p > bound if self.e < 0 else log_p < bound
        return bound if beyond else None

    # ------------------------------------------------------------ steps
    def onset_ratios(self, seed_peak: float, seed_contact: int) -> list[float] | None:
        """P_k/P_{k-1} for the ONSET contacts after the seed; None: the pulse dies in the onset."""
        out = []
        for k in range(1, ONSET + 1):
            local = self._local(seed_contact + k)
            if local is None:
                out.append(1.0)
                continue
            sign, log_lam = local
            tab = self.table(sign)
            log_p = log_lam + math.log(seed_peak)
            bound = self._small_side(log_p, tab)
            at = log_p if bound is None else bound
            tab.ensure_entry(at)
            ratios = tab.onset_ratios(at)
            if ratios is None:
                return None
            value = ratios[k - 1]
            if bound is not None:
                value *= math.exp(self.e * (log_p - bound))  # linear in x below X_SMALL
            out.append(math.exp(value))
        return out

    def bulk_ratio(self, peak: float, contact: int) -> float | None:
        """F(P)/P for the step onto ``contact``; None where no relaxed pulse exists (it dies)."""
        local = self._local(contact)
        if local is None:
            return 1.0
        sign, log_lam = local
        tab = self.table(sign)
        log_p = log_lam + math.log(peak)
        bound = self._small_side(log_p, tab)
        at = log_p if bound is None else bound
        if not tab.cover(at):
            return None
        fit = tab.bulk()
        if fit is None:
            return None
        value = float(fit(at))
        if bound is not None:
            value *= math.exp(self.e * (log_p - bound))
        return math.exp(value)

    def accuracy(self) -> float:
        """Stated accuracy of the bulk map: the worst leave-one-run-out error in log r."""
        return max((leave_one_out(t) for t in self.tables.values() if len(t.runs) > 2), default=float("nan"))

    def segment_runs(self) -> int:
        return sum(len(t.runs) for t in self.tables.values())


@dataclass(frozen=True)
class RelaxedRun:
    """Peaks the relaxed map predicts on contacts seed+1.. (status "ok" or "died")."""

    contacts: np.ndarray
    peaks: np.ndarray
    status: str
    message: str
    seed_peak: float
    seed_contact: int


def iterate_relaxed(model: RelaxedModel, seed_peak: float, seed_contact: int, last_contact: int,
                    death_fraction: float = 1e-3) -> RelaxedRun:
    """Onset then relaxed map from P_{seed_contact} = seed_peak through ``last_contact``."""
    if not (isinstance(seed_peak, (int, float)) and math.isfinite(seed_peak) and seed_peak > 0):
        raise RelaxedError(f"seed_peak must be a finite number > 0, got {seed_peak!r}")
    if last_contact <= seed_contact:
        raise RelaxedError(f"last contact {last_contact} must come after the seed contact {seed_contact}")
    contacts, peaks = [], []
    status, message = "ok", f"reached contact {last_contact}"
    p = float(seed_peak)
    onset = model.onset_ratios(p, seed_contact)
    if onset is None:
        return RelaxedRun(np.zeros(0, int), np.zeros(0), "died", f"the pulse dies within the onset "
                          f"(segment runs entering at peak {p:.4g} die within {ONSET} contacts)", p, seed_contact)
    for c in range(seed_contact + 1, last_contact + 1):
        k = c - seed_contact
        r = onset[k - 1] if k <= ONSET else model.bulk_ratio(p, c)
        if r is None:
            status, message = "died", (f"no relaxed pulse at peak {p:.4g} (segment runs there die before they "
                                       f"relax): the pulse dies after contact {c - 1}")
            break
        p *= r
        if p < death_fraction * seed_peak:
            status, message = "died", f"pulse died at contact {c}: peak below {death_fraction:g} of the seed"
            break
        contacts.append(c)
        peaks.append(p)
    return RelaxedRun(np.array(contacts, int), np.array(peaks), status, message, float(seed_peak), seed_contact)


# ----------------------------------------------------------------------------- construction


def _monomial_text(a: int, b: int, sign: int) -> str:
    parts = [f"u^{a}" if a else "", f"v^{b}" if b else ""]
    body = "*".join(x for x in parts if x)
    return body if sign > 0 else f"-{body}"


def build_model(R, R_text: str, used: tuple[str, ...], values: Mapping[str, object], eps: float, n: float,
                coefficients: np.ndarray | None, *, rtol: float = 1e-9) -> RelaxedModel:
    """The relaxed model of eps R (sympy ``R``, its text, used parameter names and values).

    ``coefficients``: eps_i R_i(1, 1) per bead (the monomial's local coefficient); needed for a
    single monomial, ignored otherwise. Site-dependent R with several monomials is refused.
    """
    from pulsemap.symbolic.scaling import monomial_exponents, scaling_exponent

    if not (math.isfinite(eps) and eps >= 0):
        raise RelaxedError(f"eps must be a finite number >= 0, got {eps!r}")
    site = any(np.ndim(values[k]) for k in used) or "i" in {s.name for s in R.free_symbols}
    mono = monomial_exponents(R)
    e = None if mono is None else scaling_exponent(*mono, n)
    if mono is not None and abs(e) > 1e-12:
        if coefficients is None:
            raise RelaxedError("a single-monomial R needs its per-bead coefficients eps_i R_i(1, 1)")
        spec = SegmentSpec(_monomial_text(*mono, 1), (), 1.0, float(n), rtol)
        return RelaxedModel(float(n), spec, {}, np.asarray(coefficients, float), e, mono)
    if site:
        raise RelaxedError(f"relaxed: R = {R_text} varies along the chain and is not a single monomial c_i u^a v^b "
                           "with a scaling exponent e != 0; the relaxed map needs R uniform, or one such monomial "
                           "(used at its local coefficient)")
    params = tuple(sorted((k, float(values[k])) for k in used))
    spec = SegmentSpec(R_text, params, float(eps), float(n), rtol)
    return RelaxedModel(float(n), spec, {0: SegmentTable(spec)})


def bead_coefficients(force_mod, used: tuple[str, ...], values: Mapping[str, object], eps: float,
                      first_perturbed: int, beads: int) -> np.ndarray:
    """eps_i R_i(1, 1) for beads 1..beads (zero before first_perturbed) from the generated force."""
    force = onsite_force(force_mod, beads, first_perturbed, eps, values)
    ones = np.ones(beads)
    with np.errstate(all="ignore"):
        c = np.asarray(force.force(ones, ones), float)
    if not np.all(np.isfinite(c)):
        raise RelaxedError("R(1, 1) is not finite on every bead: cannot read the monomial's coefficients")
    return c


def model_for_scene(scene, values: Mapping[str, object], *, rtol: float = 1e-9) -> RelaxedModel:
    """The relaxed model of a scene's eps R (``values``: its parameters, scalars or per-bead arrays)."""
    from pulsemap.symbolic.scaling import monomial_exponents
    from pulsemap.solvers.models.codeload import force_module

    pert = scene.perturbation
    coef = None
    if monomial_exponents(pert.R) is not None:
        lengths = [np.size(values[k]) for k in pert.used_parameters if np.ndim(values[k])]
        beads = min(lengths) if lengths else int(scene.contacts[1]) + 2
        coef = bead_coefficients(force_module(pert.text, pert.used_parameters), pert.used_parameters, values,
                                 float(pert.eps), int(scene.first_perturbed), beads)
    return build_model(pert.R, pert.text, pert.used_parameters, values, float(pert.eps), float(scene.exponent), coef, rtol=rtol)
