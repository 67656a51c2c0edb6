"""The relaxed transfer map with its onset: a reduced model built from the DNS itself.

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
eps, c and v0 by the amplitude change A' = |eps c|^(1/e) A. Several monomials (or a non-polynomial
R, or e = 0) get tables of their own R, eps and params; where R varies along the chain, a homogeneous
R = c h(u, v) (Coulomb friction sign(v), v*abs(v)) is read through the scaling like a monomial.
Below |x| = X_SMALL the log-ratios are continued linearly in x (first order in the perturbation),
which covers c = 0 exactly.

Site-dependent R (graded, modulated or random foundations): a bead's coefficient acts on the
pulse over several contacts, so the step onto contact c mixes the uniform map over the
coefficients of beads c + j, j = J_MIN..J_MAX: log r_c = sum_j w_j(P) log r(P; c_{c+j}), with
w_j the shares of a first-order response kernel measured by segment runs with one bumped bead
(solvers/models/relaxed_kernel.py), plus a second-order term in the window's departures from its
mean measured as the mixing's own residual on runs with one or two beads changed (none for an R with
a jump, smooth_response). The onset steps, whose pulse has not relaxed, are the onset
table at the mean coefficient of the beads they see plus a second-order onset kernel in the
departures from it (runs with one or two bumped beads). Where the window is uniform the map and
the onset are the local ones, bit for bit. A single monomial (or homogeneous R) reads the
coefficient c_i = eps_i R_i(1, 1); several monomials take one site-dependent parameter and uniform tables at
GRID_POINTS values across its range, linear in the parameter between them. Every table and kernel is calibrated on segment runs only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import lru_cache
from typing import Mapping

import numpy as np

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.chain.force_table import monomial_text
from pulsemap.solvers.models.onsite import onsite_force
from pulsemap.solvers.models.relaxed_kernel import J_MAX, J_MIN, ONSET_BEADS, KernelTable
from pulsemap.solvers.models.relaxed_table import SegmentSpec, SegmentTable, leave_one_out

X_SMALL = 1e-3  # |x| below which a monomial's log-ratios are continued linearly in x


class RelaxedError(PulsemapError):
    """A perturbation or argument the relaxed map cannot take (and why)."""


@dataclass
class RelaxedModel:
    """Onset and bulk tables and how a scene's amplitudes map onto them.

    ``coefficients``: eps_i c_i per bead (1-based at index i-1) for the monomial path, the
    site-dependent parameter's values on the grid path, None for a table of the scene's own R.
    ``e``: the monomial's scaling exponent, ``units`` the texts of its tables of coefficient +1 and -1.
    ``tables``: one per sign of the coefficient (monomial path), one per grid point (grid path: ``grid``
    the parameter ``param``'s values), or {0: the scene's table}. ``kernels``: the response kernel of
    each table a site-dependent R needs.
    """

    n: float
    spec: SegmentSpec
    tables: dict
    coefficients: np.ndarray | None = None
    e: float | None = None
    units: tuple[str, str] | None = None
    first_perturbed: int = 1
    kernels: dict = field(default_factory=dict)
    grid: tuple[float, ...] | None = None
    param: str | None = None
    second_order: bool = True  # the bulk's second-order term (False: the mixing alone; smooth_response)

    # ------------------------------------------------------------ amplitude change
    def _scale(self, c: float | None) -> tuple[int, float] | None:
        """(table sign, log lambda) of coefficient c (None: the scene's own table); None for c = 0."""
        if c is None:
            return 0, 0.0
        if c == 0.0:
            return None
        return (1 if c > 0 else -1), math.log(abs(c)) / self.e

    def _coef(self, bead: int) -> float:
        return float(self.coefficients[min(max(bead, 1), len(self.coefficients)) - 1])

    def _bulk_window(self, contact: int) -> tuple[float, list[float]]:
        """(own, window): the coefficients of beads contact + j, J_MIN <= j <= J_MAX, a bead before
        first_perturbed counting as the contact's own coefficient (the segment runs enter bare)."""
        own = self._coef(contact)
        return own, [self._coef(contact + j) if contact + j >= self.first_perturbed else own
                     for j in range(J_MIN, J_MAX + 1)]

    def _departures(self, window, mean: float) -> np.ndarray:
        """The window's departures from its mean, as the kernels take them: relative (c / cm - 1) for a
        monomial's coefficient, absolute (c - cm) for a parameter on the grid."""
        return np.asarray(window) - mean if self.grid is not None else np.asarray(window) / mean - 1.0

    def mix(self, contact: int, peak: float) -> list[tuple[float, float | None]]:
        """[(w_j, c_j)]: log r of the step onto ``contact`` at peak P is sum_j w_j log r(P; c_j), the
        uniform map at the coefficient c_j of bead contact + j (J_MIN <= j <= J_MAX) weighted by the
        response kernel's shares at the window's mean coefficient (relaxed_kernel.KernelTable.weights).
        To first order in the departures from the mean this is the kernel's own correction. Where
        the window is uniform: [(1, own)], today's local map exactly. Beads before first_perturbed
        count as the contact's own coefficient (the segment runs enter bare, like the scene)."""
        if self.coefficients is None:
            return [(1.0, None)]
        own, window = self._bulk_window(contact)
        if all(c == own for c in window):
            return [(1.0, own)]
        key, tab, at = self._reference(window, own, peak)
        w = self.kernel(key).weights(at) if tab.cover(at) else None
        if w is None:
            return [(1.0, own)]
        return [(float(wj), c) for wj, c in zip(w, window) if wj != 0.0]

    def onset_log_ratio(self, k: int, seed_contact: int, seed_peak: float) -> float | None:
        """log P_k/P_{k-1} of onset step k (onto contact seed_contact + k) after entry at seed_peak:
        the onset table at the mean coefficient cm of beads seed_contact + 1 + b, b = 0..ONSET_BEADS-1,
        plus the onset kernel's first- and second-order terms in their departures e_b (relative,
        c_b / cm - 1, for a monomial; c_b - cm for a parameter): sum_b H_b e_b + 1/2 sum H2_bb' e_b e_b'
        (relaxed_kernel.KernelTable.onset_kernel). Where the window is uniform, the local onset
        exactly. None: the pulse dies within the onset."""
        own = None if self.coefficients is None else self._coef(seed_contact + k)
        window = [] if own is None else [self._coef(seed_contact + 1 + b) for b in range(ONSET_BEADS)]
        if own is None or all(c == own for c in window):
            return self._log_onset(own, seed_peak, k)
        mean = float(np.mean(window))
        key, tab, at = self._reference(window, own, seed_peak)
        tab.ensure_entry(at)
        kern = self.kernel(key).onset_kernel(at) if (self.grid is not None or mean != 0.0) else None
        base = self._log_onset(mean, seed_peak, k)
        if kern is None or base is None:
            return self._log_onset(own, seed_peak, k)
        h, h2 = kern[0][:, k - 1], kern[1][:, :, k - 1]
        e = self._departures(window, mean)
        return base + float(h @ e) + 0.5 * float(e @ h2 @ e)

    def _reference(self, window: list[float], own: float, peak: float) -> tuple[int, SegmentTable, float]:
        """(key, table, log P on it) where a window's kernel is read: at the window's mean coefficient."""
        ref = float(np.mean(window))
        if self.grid is not None:  # the kernel of the grid table nearest the window's mean
            key = int(np.argmin(np.abs(np.asarray(self.grid) - ref)))
            tab, at = self.table(key), math.log(peak)
        else:
            key = 1 if ref > 0 else -1 if ref < 0 else (1 if own >= 0 else -1)
            tab = self.table(key)
            if ref == 0.0:
                at = self._bound()
            else:
                log_p = math.log(abs(ref)) / self.e + math.log(peak)
                bound = self._small_side(log_p, tab)
                at = log_p if bound is None else bound
        return key, tab, at

    def kernel(self, key: int) -> KernelTable:
        """The response kernel of table ``key`` (of R's scale; of the parameter on the grid path)."""
        if key not in self.kernels:
            self.kernels[key] = KernelTable(self.table(key), self.param or "")
        return self.kernels[key]

    def table(self, key: int) -> SegmentTable:
        """The table of a sign of the monomial's coefficient, or of grid point ``key`` (grid path)."""
        if key not in self.tables and self.grid is not None:
            params = tuple(sorted({**dict(self.spec.params), self.param: float(self.grid[key])}.items()))
            self.tables[key] = SegmentTable(replace(self.spec, params=params))
        if key not in self.tables:
            text = self.units[0 if key > 0 else 1]
            self.tables[key] = SegmentTable(SegmentSpec(text, (), 1.0, self.n, self.spec.rtol,
                                                        self.spec.window_accuracy))
        return self.tables[key]

    def _bound(self) -> float:
        """log P' where |x| = (P'/S0)^e = X_SMALL (monomial path)."""
        from pulsemap.symbolic.profile import exact_profile

        return math.log(exact_profile(self.n).S0) + math.log(X_SMALL) / self.e

    def _small_side(self, log_p: float, table: SegmentTable) -> float | None:
        """log P' of the X_SMALL boundary when log_p lies beyond it (monomial path), else None."""
        if self.e is None:
            return None
        bound = self._bound()
        beyond = log_p > bound if self.e < 0 else log_p < bound
        return bound if beyond else None

    # ------------------------------------------------------------ steps
    def _where(self, c: float | None, peak: float) -> list[tuple[float, SegmentTable, float, float | None]]:
        """[(weight, table, log P' on it, X_SMALL boundary or None)] whose weighted log ratios are the
        uniform chain's at coefficient c: one table (the scene's, or the monomial's sign at the scaled
        amplitude; none for c = 0), or the two grid tables around parameter value c (linear in c)."""
        if self.grid is not None:
            g = self.grid
            i = min(max(int(np.searchsorted(g, c)) - 1, 0), len(g) - 2)
            t = min(max((c - g[i]) / (g[i + 1] - g[i]), 0.0), 1.0)
            return [(w, self.table(k), math.log(peak), None) for w, k in ((1.0 - t, i), (t, i + 1)) if w != 0.0]
        scale = self._scale(c)
        if scale is None:
            return []
        sign, log_lam = scale
        tab = self.table(sign)
        log_p = log_lam + math.log(peak)
        return [(1.0, tab, log_p, self._small_side(log_p, tab))]

    def _log_onset(self, c: float | None, seed_peak: float, k: int) -> float | None:
        """log P_k/P_{k-1} after entry at seed_peak on the uniform chain of coefficient c (None: dies)."""
        total = 0.0
        for weight, tab, log_p, bound in self._where(c, seed_peak):
            at = log_p if bound is None else bound
            tab.ensure_entry(at)
            ratios = tab.onset_ratios(at)
            if len(ratios) < k:
                return None
            value = ratios[k - 1]
            if bound is not None:
                value *= math.exp(self.e * (log_p - bound))  # linear in x below X_SMALL
            total += weight * value
        return total

    def _log_bulk(self, c: float | None, peak: float) -> float | None:
        """log F(P)/P of the uniform chain of coefficient c (None: no relaxed pulse there)."""
        total = 0.0
        for weight, tab, log_p, bound in self._where(c, peak):
            at = log_p if bound is None else bound
            if not tab.cover(at):
                return None
            fit = tab.bulk()
            if fit is None:
                return None
            value = float(fit(at))
            if bound is not None:
                value *= math.exp(self.e * (log_p - bound))
            total += weight * value
        return total

    def onset_ratios(self, seed_peak: float, seed_contact: int) -> list[float]:
        """P_k/P_{k-1} for the onset's contacts after the seed (the spec's onset: ONSET for an on-site R), up to
        the first the pulse does not reach (fewer: it dies within the onset, as the segment runs entering at
        seed_peak do)."""
        out = []
        for k in range(1, self.spec.onset + 1):
            value = self.onset_log_ratio(k, seed_contact, seed_peak)
            if value is None:
                break
            out.append(math.exp(value))
        return out

    def bulk_ratio(self, peak: float, contact: int) -> float | None:
        """F(P)/P for the step onto ``contact``; None where no relaxed pulse exists (it dies). A non-uniform
        window adds the second-order term (``second_order_term``) to the mixing of uniform maps."""
        terms = [(w, self._log_bulk(c, peak)) for w, c in self.mix(contact, peak)]
        if any(v is None for _, v in terms):
            value = self._linear_bulk(contact, peak) if len(terms) > 1 else None
            return None if value is None else math.exp(value)
        value = sum(w * v for w, v in terms)
        if len(terms) > 1 and self.second_order:
            value += self.second_order_term(contact, peak)
        return math.exp(value)

    def second_order_term(self, contact: int, peak: float) -> float:
        """1/2 sum_jj' Q_jj'(P) e_j e_j': what the mixing of uniform maps misses at second order in the window's
        departures e_j from its mean (relative for a monomial's coefficient, absolute for a parameter), Q
        the second derivatives of the model's own one-step residual on segment runs with one or two beads
        changed (relaxed_kernel.KernelTable.hessian) at the window's mean, where the kernel's shares are read.
        Without it the mixing decays too fast by a share growing as the departures' square (docs/nonuniform.rst
        has the size). 0 where a coefficient is 0 or of the other sign than the mean (the first-order
        mixing alone there)."""
        own, window = self._bulk_window(contact)
        mean = float(np.mean(window))
        if self.grid is None and (mean == 0.0 or any(c * mean <= 0.0 for c in window)):
            return 0.0
        key, tab, at = self._reference(window, own, peak)
        if not tab.cover(at):
            return 0.0
        e = self._departures(window, mean)
        return 0.5 * float(e @ self.kernel(key).hessian(at, self._residual(key)) @ e)

    def _residual(self, key: int):
        """residual(bump, peaks) -> {step m: log(P_m/P_{m-1}) less the mixing's at P_{m-1}} for a segment run of
        table ``key`` with ``bump`` (KernelTable.hessian): the model without its second-order term on the run's
        chain (R's scale or the parameter on bead first_perturbed + b changed), sharing its tables and kernels."""
        tab = self.table(key)
        _, fp, entry = tab.spec.geometry()
        beads = entry + tab.spec.recorded + 2 * (J_MAX - J_MIN) + 2
        if self.grid is not None:
            base = np.full(beads, float(self.grid[key]))
        else:
            base = np.where(np.arange(1, beads + 1) >= fp, float(key), 0.0)

        def residual(bump, peaks: list[float]) -> dict[int, float]:
            coef = base.copy()
            for b, delta, _ in bump:
                coef[fp - 1 + b] += delta if self.grid is not None else coef[fp - 1 + b] * delta
            run = replace(self, coefficients=coef, first_perturbed=fp, second_order=False)
            out = {}
            for m in range(self.spec.onset + 1, len(peaks)):
                r = run.bulk_ratio(peaks[m - 1], entry + m)
                if r is None:
                    break
                out[m] = math.log(peaks[m] / peaks[m - 1]) - math.log(r)
            return out

        return residual

    def _linear_bulk(self, contact: int, peak: float) -> float | None:
        """log F(P)/P as the uniform map at the window's mean coefficient cm plus the kernel's first-order
        terms sum_j G_j e_j (e_j = c_j / cm - 1; a parameter: c_j - cm): the step where the uniform map
        of some neighbour's coefficient has no relaxed pulse at P (its segment runs die before they
        relax) but the mean's has. None: no relaxed pulse at the mean either (the pulse dies)."""
        own, window = self._bulk_window(contact)
        mean = float(np.mean(window))
        base = self._log_bulk(mean, peak)
        if base is None or (self.grid is None and mean == 0.0):
            return None
        key, tab, at = self._reference(window, own, peak)
        if not tab.cover(at):
            return None
        e = self._departures(window, mean)
        return base + float(self.kernel(key).kernel(at) @ e)

    def ending(self, contact: int, peak: float) -> str:
        """How the segment runs of the step onto ``contact`` at ``peak`` end where no relaxed pulse exists:
        "blow up" or "die" (SegmentTable.ending, on the table of the contact's own coefficient)."""
        own = None if self.coefficients is None else self._coef(contact)
        for _, tab, log_p, bound in self._where(own, peak):
            return tab.ending(log_p if bound is None else bound)
        return "die"

    def accuracy(self) -> float:
        """Stated accuracy of the bulk map: the worst leave-one-run-out error in log r."""
        return max((leave_one_out(t) for t in self.tables.values() if len(t.runs) > 2), default=float("nan"))

    def segment_runs(self) -> int:
        return sum(len(t.runs) for t in self.tables.values()) + self.kernel_runs()

    def kernel_runs(self) -> int:
        """Bumped segment runs of the response kernels: the bulk kernel's, the onset kernel's and the second-order
        runs."""
        onset = sum(len(k.onset_bumps()) for k in self.kernels.values() for h in k.onset_runs.values() if h is not None)
        pairs = sum(len(k.pair_bumps()) * len(k.pair_runs) for k in self.kernels.values())
        return sum(len(k.runs) for k in self.kernels.values()) + onset + pairs


@dataclass(frozen=True)
class RelaxedRun:
    """Peaks the relaxed map predicts on contacts seed+1.. (status "ok", "died" or "blow-up")."""

    contacts: np.ndarray
    peaks: np.ndarray
    status: str
    message: str
    seed_peak: float
    seed_contact: int


_ENDS = {"die": ("died", "dies"), "blow up": ("blow-up", "blows up")}  # (status, verb) by how segment runs end


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
    onset_steps = model.spec.onset
    for c in range(seed_contact + 1, last_contact + 1):
        k = c - seed_contact
        if len(onset) < k <= onset_steps:
            end = model.ending(seed_contact + 1, float(seed_peak))
            status, message = _ENDS[end][0], (f"the pulse {_ENDS[end][1]} within the onset after contact {c - 1} "
                                              f"(segment runs entering at peak {seed_peak:.4g} {end} within {k} "
                                              f"contact{'s' if k > 1 else ''})")
            break
        r = onset[k - 1] if k <= onset_steps else model.bulk_ratio(p, c)
        if r is None:
            end = model.ending(c, p)
            status, message = _ENDS[end][0], (f"no relaxed pulse at peak {p:.4g} (segment runs there {end} before "
                                              f"they relax): the pulse {_ENDS[end][1]} after contact {c - 1}")
            break
        p *= r
        if p < death_fraction * seed_peak:
            status, message = "died", f"pulse died at contact {c}: peak below {death_fraction:g} of the seed"
            break
        contacts.append(c)
        peaks.append(p)
    return RelaxedRun(np.array(contacts, int), np.array(peaks), status, message, float(seed_peak), seed_contact)


# ----------------------------------------------------------------------------- construction


def varies(R, used: tuple[str, ...], values: Mapping[str, object]) -> bool:
    """Whether eps R changes along the chain: a per-bead parameter, or the bead index i in R."""
    return any(np.ndim(values[k]) for k in used) or "i" in {s.name for s in R.free_symbols}


def smooth_response(R) -> bool:
    """Whether the pulse's response to a bead's coefficient is smooth enough for the bulk's second-order term: not
    for an R with a jump (sign, Heaviside: Coulomb friction), whose beads stick behind the pulse where the force
    is below the jump, so the response has kinks; on segment runs through random friction the term came out
    larger than the mixing's residual it was to remove (docs/nonuniform.rst)."""
    import sympy

    return not R.has(sympy.sign, sympy.Heaviside)


@lru_cache(maxsize=64)
def scaling_form(R, n: float, site: bool) -> tuple[tuple[str, str], float] | None:
    """((the texts of the tables of coefficient +1 and -1), e) of an R the scaling of Eq. 1 carries: a single
    monomial c u^a v^b; and, where R varies along the chain, a homogeneous R = c h(u, v) (sign(v), v*abs(v):
    derive/scaling.homogeneous_form), which otherwise gets a grid of tables linear in c between them. None:
    neither (a uniform non-monomial R keeps its own table)."""
    from pulsemap.symbolic.scaling import homogeneous_form, monomial_exponents, scaling_exponent

    mono = monomial_exponents(R)
    if mono is not None:
        return (monomial_text(*mono), f"-{monomial_text(*mono)}"), scaling_exponent(*mono, n)
    form = homogeneous_form(R, n) if site else None
    return None if form is None else ((form[0], f"-({form[0]})"), form[1])


def build_model(R, R_text: str, used: tuple[str, ...], values: Mapping[str, object], eps: float, n: float,
                coefficients: np.ndarray | None, *, rtol: float = 1e-9,
                first_perturbed: int | None = None) -> RelaxedModel:
    """The relaxed model of eps R (sympy ``R``, its text, used parameter names and values).

    ``coefficients``: eps_i R_i(1, 1) per bead (the monomial's local coefficient); needed for a
    single monomial or a site-dependent homogeneous R (``scaling_form``), ignored otherwise.
    ``first_perturbed`` (default: the first bead with a nonzero coefficient; required for a
    site-dependent R of several monomials): beads before it are the bare chain the segment runs enter
    from. A site-dependent R of several monomials takes one
    site-dependent parameter and no explicit bead index i (``_grid_model``).
    """
    if not (math.isfinite(eps) and eps >= 0):
        raise RelaxedError(f"eps must be a finite number >= 0, got {eps!r}")
    site = varies(R, used, values)
    form = scaling_form(R, n, site)
    if form is not None and abs(form[1]) > 1e-12:
        if coefficients is None:
            raise RelaxedError("a single-monomial or homogeneous R needs its per-bead coefficients eps_i R_i(1, 1)")
        spec = SegmentSpec(form[0][0], (), 1.0, float(n), rtol)
        coef = np.asarray(coefficients, float)
        if first_perturbed is None:
            first_perturbed = int(np.argmax(coef != 0.0)) + 1 if np.any(coef != 0.0) else 1
        return RelaxedModel(float(n), spec, {}, coef, form[1], form[0], int(first_perturbed),
                            second_order=smooth_response(R))
    if site:
        return _grid_model(R, R_text, used, values, eps, n, rtol, first_perturbed)
    params = tuple(sorted((k, float(values[k])) for k in used))
    spec = SegmentSpec(R_text, params, float(eps), float(n), rtol)
    return RelaxedModel(float(n), spec, {0: SegmentTable(spec)})


GRID_POINTS = 9  # uniform tables across a site-dependent parameter's range (several monomials)


def _grid_model(R, R_text: str, used: tuple[str, ...], values: Mapping[str, object], eps: float, n: float,
                rtol: float, first_perturbed: int | None) -> RelaxedModel:
    """Site-dependent R with several monomials: uniform tables at GRID_POINTS values of its one
    site-dependent parameter, the map linear in the parameter between them, mixed over neighbours
    by the parameter's response kernel (RelaxedModel.mix)."""
    if "i" in {s.name for s in R.free_symbols}:
        raise RelaxedError(f"relaxed: R = {R_text} depends on the bead index i and is not a single monomial; write "
                           "the bead-dependent part as a parameter (a list, a random draw or an expression of i)")
    varying = [k for k in used if np.ndim(values[k])]
    if len(varying) != 1:
        raise RelaxedError(f"relaxed: R = {R_text} has {len(varying)} site-dependent parameters "
                           f"({', '.join(varying)}); a relaxed model with several monomials takes one")
    name = varying[0]
    if first_perturbed is None:
        raise RelaxedError("relaxed: a site-dependent R with several monomials needs first_perturbed")
    theta = np.asarray(values[name], float)
    if not np.all(np.isfinite(theta)):
        raise RelaxedError(f"relaxed: parameter {name} is not finite on every bead")
    lo, hi = float(theta[first_perturbed - 1:].min()), float(theta[first_perturbed - 1:].max())
    grid = tuple(np.linspace(lo, hi, GRID_POINTS).tolist()) if hi > lo else (lo, lo + 1.0)
    params = tuple(sorted((k, float(values[k]) if k != name else lo) for k in used))
    spec = SegmentSpec(R_text, params, float(eps), float(n), rtol)
    return RelaxedModel(float(n), spec, {}, theta, None, None, int(first_perturbed), grid=grid, param=name,
                        second_order=smooth_response(R))


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


def contact_model(scene, values: Mapping[str, object], rtol: float) -> RelaxedModel:
    """The relaxed model of a scene with a uniform contact-law term (and a uniform R or none): tables of segment
    runs launched into the chain with both, from the scene's first perturbed contact on."""
    law, pert = scene.contact, scene.perturbation
    if scene.masses is not None:
        raise RelaxedError("relaxed: a chain with masses has no relaxed model yet (its pulse has no fixed shape "
                           "to relax to); energy-law and the DNS run it")
    if law.first_perturbed != scene.first_perturbed:
        raise RelaxedError(f"relaxed: the contact term starts at contact {law.first_perturbed} and R at bead "
                           f"{scene.first_perturbed}: the segment runs enter both at once; give one first_perturbed")
    exps, coef = law.table(scene.first_perturbed + 1)
    if any(s.name == "k" for m in law.monomials for s in m.coef.free_symbols) or \
            any(not isinstance(v, float) for v in law.params.values()) or \
            (pert.acts and varies(pert.R, pert.used_parameters, values)):
        raise RelaxedError("relaxed: a contact term or R that varies along the chain has no relaxed model yet; "
                           "energy-law and the DNS run it")
    R_text = pert.text if pert.acts else "0"
    params = tuple(sorted((k, float(values[k])) for k in pert.used_parameters)) if R_text != "0" else ()
    contact = tuple((float(a), float(b), float(c)) for (a, b), c in zip(exps, coef[:, -1]))
    spec = SegmentSpec(R_text, params, float(pert.eps), float(scene.exponent), rtol, contact=contact)
    return RelaxedModel(float(scene.exponent), spec, {0: SegmentTable(spec)})


def model_for_scene(scene, values: Mapping[str, object], *, rtol: float = 1e-9) -> RelaxedModel:
    """The relaxed model of a scene's eps R (``values``: its parameters, scalars or per-bead arrays), with its
    contact-law term when it has one (contact_model)."""
    from pulsemap.solvers.models.codeload import force_module

    if getattr(scene, "contact", None) is not None or getattr(scene, "masses", None) is not None:
        return contact_model(scene, values, rtol)
    pert = scene.perturbation
    coef = None
    if scaling_form(pert.R, float(scene.exponent), varies(pert.R, pert.used_parameters, values)) is not None:
        lengths = [np.size(values[k]) for k in pert.used_parameters if np.ndim(values[k])]
        beads = min(lengths) if lengths else int(scene.contacts[1]) + 2
        coef = bead_coefficients(force_module(pert.text, pert.used_parameters), pert.used_parameters, values,
                                 float(pert.eps), int(scene.first_perturbed), beads)
    return build_model(pert.R, pert.text, pert.used_parameters, values, float(pert.eps), float(scene.exponent), coef,
                       rtol=rtol, first_perturbed=int(scene.first_perturbed))
