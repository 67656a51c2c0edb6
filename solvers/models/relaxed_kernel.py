"""Response of the relaxed map to neighbouring beads' coefficients (bulk and onset: to second order), from segment runs.

A bead's on-site coefficient acts on the primary pulse over several contacts, not only on the step
whose first bead it is. For a segment table (relaxed_table.SegmentTable, uniform R) the kernel is

    G_j(P) = d log(P_{c}/P_{c-1}) / d(log of R's scale on bead c + j)

(or d/d(a parameter on bead c + j)): the change of the step onto contact c when R (or the
parameter) on one bead, j places after the contact's first bead, is changed. It is measured, for
each launch amplitude of the table, by one segment run with R on bead first_perturbed + BUMP_BEAD
scaled by 1 + DELTA (a parameter: moved by DELTA max(|value|, 0.1)) against the table's own run,
read off the relaxed part of the run (contacts after the onset): the step onto the run's m-th
contact sees the bump at j = BUMP_BEAD + 1 - m. The part of that change the map itself carries
(the bump's earlier effect on P_{c-1} times the bulk map's slope d log r/d log P) is taken off,
so that iterating the map with the kernel counts each effect once. Points are interpolated in
log P_{c-1} per j (clamped at the ends). Sum_j G_j(P) is the derivative of the uniform map in the
varied quantity (tests/models/test_relaxed_kernel.py checks it). The map uses the kernel's shares
G_j / sum_j G_j (``weights``). Runs are cached like the table's.

The onset (the ONSET steps after the bare entry) is not translation invariant and its pulse has not
relaxed, so it has a kernel of its own (``onset_kernel``): the first and second derivatives of its
log ratios in the coefficients of beads first_perturbed + 0..ONSET_BEADS-1, from runs with one bead
(+-ONSET_DELTA) or two beads (+ONSET_DELTA each) bumped, at the entry peak of the base run.

The bulk's second order (``hessian``) is what the map's mixing of uniform maps misses: the second
derivatives Q_jj' of the model's own one-step residual (the run's log ratio less the model's, read at
the run's incoming peak) in the coefficients of beads c + j and c + j', from runs with bead BUMP_BEAD
and bead BUMP_BEAD + d changed together by +-PAIR_DELTA (d = 0: that bead alone), each run's
residual less the base run's. The sum of the +PAIR_DELTA and -PAIR_DELTA runs cancels the odd orders
(the first-order kernel's own error among them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from pulsemap.symbolic import cache
from pulsemap.solvers.models.relaxed_table import (
    LATTICE,
    NAMESPACE,
    ONSET,
    SegmentTable,
    cached_segment,
    lattice_amplitude,
    segment_peaks,
)

J_MIN, J_MAX = -4, 2  # the kernel's span in beads (behind the contact's first bead .. ahead of it)
BUMP_BEAD = ONSET + J_MAX  # the bumped bead, after first_perturbed: steps ONSET+1.. see j = J_MAX, J_MAX-1, ..
SLOPE_STEP = 1e-3  # half-step in log P of the bulk map's slope d log r / d log P
DELTA = 0.02  # relative change of R on the bumped bead (a one-sided difference: the kernel's shares to O(DELTA))
ONSET_BEADS = ONSET + J_MAX  # beads first_perturbed + 0.. the onset kernel spans (the last onset step's window)
ONSET_DELTA = 0.1  # bump of the onset kernel's runs (second differences: larger than DELTA)
#: bump of the bulk's second-order runs: a second difference divides the table's fit error by its square, so a
#: small bump's noise outweighs the correction on mild contrasts; larger bumps do alike on segment runs through
#: two-valued chains (docs/nonuniform.rst has the comparison)
PAIR_DELTA = 0.3
PAIR_LIFE = 3  # contacts every second-order run must live past a step for it to count (see _hessian_at)
PAIR_REACH = 2.0 * math.log(2.0) / LATTICE  # two lattice spacings: the runs bracketing log P for every j


@dataclass
class KernelTable:
    """G_j(log P) for j = J_MIN..J_MAX, from bumped segment runs at the table's lattice points."""

    table: SegmentTable
    param: str = ""  # "": R's scale on the bead; else the parameter the kernel is of
    runs: dict = field(default_factory=dict)  # lattice j -> peaks of the bumped run
    onset_runs: dict = field(default_factory=dict)  # lattice j -> its onset kernel (H, H2), or None
    pair_runs: dict = field(default_factory=dict)  # lattice j -> peaks of the second-order runs (pair_bumps order)
    pair_points: dict = field(default_factory=dict)  # lattice j -> its second-order points (_hessian_at)
    _fits: dict | None = None
    _hessian: dict | None = None

    def bump(self, delta: float) -> float:
        """A bump of relative size ``delta``: of R's scale, or of the parameter (at least 0.1 x delta)."""
        return delta if not self.param else delta * max(abs(dict(self.table.spec.params)[self.param]), 0.1)

    def step(self) -> tuple[float, float]:
        """(the bump, the change of the varied quantity it makes: log scale of R, or the parameter)."""
        d = self.bump(DELTA)
        return (d, math.log1p(d)) if not self.param else (d, d)

    def _bumped(self, j: int) -> list[float]:
        if j not in self.runs:
            self.runs[j] = cached_segment(replace(self.table.spec, bump=((BUMP_BEAD, self.step()[0], self.param),)), j)
            self._fits = None
        return self.runs[j]

    def points(self) -> dict[int, tuple[np.ndarray, np.ndarray]]:
        """Per j: (log P_{m-1}, G_j) over the lattice runs, sorted by log P."""
        pts: dict[int, list] = {j: [] for j in range(J_MIN, J_MAX + 1)}
        change = self.step()[1]
        fit = self.table.bulk()
        for lat, base in sorted(self.table.runs.items()):
            if fit is None or len(base) <= ONSET + 1:  # a run without bulk steps gives no point: no bumped run
                continue
            up, down = self._bumped(lat), base
            k = min(len(base), len(up))
            for m in range(ONSET + 1, k):
                j = BUMP_BEAD + 1 - m
                if J_MIN <= j <= J_MAX:
                    x = float(np.log(base[m - 1]))
                    d_log_r = np.log(up[m] / up[m - 1]) - np.log(down[m] / down[m - 1])
                    d_log_p = np.log(up[m - 1] / down[m - 1])  # the bump's earlier effect, which the map carries
                    slope = float(fit(x + SLOPE_STEP) - fit(x - SLOPE_STEP)) / (2.0 * SLOPE_STEP)
                    pts[j].append((x, float((d_log_r - slope * d_log_p) / change)))
        out = {}
        for j, p in pts.items():
            p.sort()
            out[j] = (np.array([a for a, _ in p]), np.array([b for _, b in p]))
        return out

    def weights(self, log_p: float) -> np.ndarray | None:
        """G_j / sum_j G_j at log P: the share of each neighbour in the step (None: no kernel measured)."""
        g = self.kernel(log_p)
        total = float(g.sum())
        return None if total == 0.0 or not np.isfinite(total) else g / total

    def kernel(self, log_p: float) -> np.ndarray:
        """G_j at log P for j = J_MIN..J_MAX (0 where no run measured that j)."""
        if self._fits is None or len(self._fits.get("lattice", ())) != len(self.table.runs):
            self._fits = {"lattice": tuple(self.table.runs), "pts": self.points()}
        out = np.zeros(J_MAX - J_MIN + 1)
        for i, j in enumerate(range(J_MIN, J_MAX + 1)):
            x, y = self._fits["pts"][j]
            if x.size:
                out[i] = float(np.interp(log_p, x, y))
        return out

    def onset_kernel(self, log_p0: float) -> tuple[np.ndarray, np.ndarray] | None:
        """(H, H2) of the onset steps after entry at log P_0 = log_p0: the first and second derivatives
        of log(P_k/P_{k-1}), k = 1..ONSET (last axis), in the relative change of R (or the change of
        the parameter) on beads first_perturbed + b, b = 0..ONSET_BEADS-1 (H[b, k-1], H2[b, b', k-1]).
        Measured by segment runs with one or two beads bumped by ONSET_DELTA (central differences
        on the diagonal, one-sided off it) at the two lattice runs around log_p0, linear in log P_0
        between them (clamped at the ends). The onset is not translation invariant (beads before the
        entry are bare) and its pulse has not relaxed, so the bulk kernel does not hold there.
        None: no lattice run lives through the onset, or a bumped run dies within it."""
        runs = sorted((math.log(p[0]), lat) for lat, p in self.table.runs.items() if len(p) > ONSET)
        if not runs:
            return None
        xs = [x for x, _ in runs]
        i = int(np.searchsorted(xs, log_p0))
        (x0, j0), (x1, j1) = runs[min(max(i - 1, 0), len(runs) - 1)], runs[min(i, len(runs) - 1)]
        t = 0.0 if x1 == x0 else min(max((log_p0 - x0) / (x1 - x0), 0.0), 1.0)
        a, b = self._onset_at(j0), self._onset_at(j1)
        if a is None or b is None:
            return None
        return (1.0 - t) * a[0] + t * b[0], (1.0 - t) * a[1] + t * b[1]

    def onset_step(self) -> float:
        """The bump of the onset kernel's runs: a relative change of R, or a change of the parameter."""
        return self.bump(ONSET_DELTA)

    def _onset_at(self, lat: int) -> tuple[np.ndarray, np.ndarray] | None:
        """(H, H2) of lattice run ``lat`` (onset_kernel), or None when a bumped run dies within the onset."""
        if lat not in self.onset_runs:
            d, p0 = self.onset_step(), math.log(self.table.runs[lat][0])
            splines = [spline for _, _, spline in self.table.onset()]
            if any(spline is None for spline in splines):
                self.onset_runs[lat] = None
                return None
            slope = np.array([float(spline(p0, 1)) for spline in splines])  # d log r_k / d log P_0

            def logr(p: list[float]) -> np.ndarray | None:
                """A run's onset log ratios at the base run's entry peak (a bump moves P_0 a little, which the
                onset table carries by itself: taken off to first order)."""
                p = np.asarray(p)
                return np.log(p[1:ONSET + 1] / p[:ONSET]) - slope * (math.log(p[0]) - p0) if len(p) > ONSET else None

            runs = [logr(p) for p in self._onset_peaks(lat)]
            if any(v is None for v in runs) or logr(self.table.runs[lat]) is None:
                self.onset_runs[lat] = None
                return None
            f0, it = logr(self.table.runs[lat]), iter(runs)
            up, down = [next(it) for _ in range(ONSET_BEADS)], [next(it) for _ in range(ONSET_BEADS)]
            h = np.array([(u - w) / (2.0 * d) for u, w in zip(up, down)])
            h2 = np.zeros((ONSET_BEADS, ONSET_BEADS, ONSET))
            for b in range(ONSET_BEADS):
                h2[b, b] = (up[b] + down[b] - 2.0 * f0) / d ** 2
                for c in range(b + 1, ONSET_BEADS):
                    h2[b, c] = h2[c, b] = (next(it) - up[b] - up[c] + f0) / d ** 2
            self.onset_runs[lat] = (h, h2)
        return self.onset_runs[lat]

    def onset_bumps(self) -> list[tuple[tuple[int, float, str], ...]]:
        """The bumps of one lattice point's onset kernel runs: +d and -d on each bead, then +d on each pair."""
        d, name = self.onset_step(), self.param
        pairs = [((b, d, name), (c, d, name)) for b in range(ONSET_BEADS) for c in range(b + 1, ONSET_BEADS)]
        return [((b, d, name),) for b in range(ONSET_BEADS)] + [((b, -d, name),) for b in range(ONSET_BEADS)] + pairs

    def _onset_peaks(self, lat: int) -> list[list[float]]:
        """Peaks of the onset kernel's runs at lattice point ``lat`` (onset_bumps order), cached as one entry."""
        return self._bumped_set(lat, self.onset_bumps(), "onset-kernel")

    # ------------------------------------------------------------ bulk, second order
    def pair_step(self) -> float:
        """The bump of the second-order runs: a relative change of R, or a change of the parameter."""
        return self.bump(PAIR_DELTA)

    def pair_bumps(self) -> list[tuple[tuple[int, float, str], ...]]:
        """The bumps of one lattice point's second-order runs: for d = 0..J_MAX-J_MIN, beads BUMP_BEAD and
        BUMP_BEAD + d (d = 0: the one bead) changed by +d, then by -d."""
        d, name = self.pair_step(), self.param
        return [tuple((b, s * d, name) for b in sorted({BUMP_BEAD, BUMP_BEAD + gap}))
                for gap in range(J_MAX - J_MIN + 1) for s in (1.0, -1.0)]

    def _pair_peaks(self, lat: int) -> list[list[float]]:
        """Peaks of the second-order runs at lattice point ``lat`` (pair_bumps order), cached as one entry."""
        if lat not in self.pair_runs:
            self.pair_runs[lat] = self._bumped_set(lat, self.pair_bumps(), "pair-kernel")
        return self.pair_runs[lat]

    def hessian(self, log_p: float, residual: Callable) -> np.ndarray:
        """Q_jj' at log P (j, j' = J_MIN..J_MAX): the second derivatives of the model's one-step residual in the
        departures of beads c + j and c + j' (relative for R's scale, absolute for a parameter), interpolated
        in log P_{c-1} per entry (clamped at the ends; 0 where no run measured it). ``residual(bump, peaks)``:
        {step m: the run's log(P_m/P_{m-1}) less the model's at P_{m-1}} of a run with ``bump`` (() for the
        table's own run). Each lattice point is read once, when log P first comes within PAIR_REACH of the
        peaks its steps see, with the tables as they stand then (a second difference of residuals of one
        fit: the fit's later growth moves it little)."""
        for lat in [lat for lat in self.table.runs if lat not in self.pair_points and self._near(lat, log_p)]:
            self.pair_points[lat] = self._hessian_at(lat, residual)
        if self._hessian is None or self._hessian["lattice"] != tuple(self.pair_points):
            pts: dict = {}
            for lat in self.pair_points:
                for jk, x, value in self.pair_points[lat]:
                    pts.setdefault(jk, []).append((x, value))
            self._hessian = {"lattice": tuple(self.pair_points), "pts": {jk: _sorted(p) for jk, p in pts.items()}}
        size = J_MAX - J_MIN + 1
        q = np.zeros((size, size))
        value = {jk: float(np.interp(log_p, x, y)) for jk, (x, y) in self._hessian["pts"].items()}
        for (j, k), v in value.items():
            if j == k:
                q[j - J_MIN, j - J_MIN] = v
        for (j, k), v in value.items():
            if j != k:
                q[j - J_MIN, k - J_MIN] = q[k - J_MIN, j - J_MIN] = 0.5 * (v - q[j - J_MIN, j - J_MIN]
                                                                       - q[k - J_MIN, k - J_MIN])
        return q

    def _near(self, lat: int, log_p: float) -> bool:
        """Whether the steps of lattice run ``lat`` that see the bumped bead start within PAIR_REACH of log P."""
        x = np.log(self.table.runs[lat][ONSET:BUMP_BEAD + 1 - J_MIN])
        return x.size > 1 and float(x.min()) - PAIR_REACH <= log_p <= float(x.max()) + PAIR_REACH

    def _hessian_at(self, lat: int, residual: Callable) -> list[tuple[tuple[int, int], float, float]]:
        """((j, j'), log P_{m-1}, (rho(+d) + rho(-d) - 2 rho(0)) / d^2) of each step m of lattice run ``lat`` that sees
        both bumped beads in its window: Q_jj for j = j', Q_jj + Q_j'j' + 2 Q_jj' for j < j'. Only steps that the run
        and all its bumped runs outlive by PAIR_LIFE contacts: near a pulse's death a bead's change moves the death,
        and the response is not quadratic in it."""
        base = self.table.runs[lat]
        if self.table.bulk() is None or len(base) <= ONSET + 1:
            return []
        runs = self._pair_peaks(lat)
        # the steps every run outlives by PAIR_LIFE contacts, up to the last whose window holds the bumped bead
        last = min(BUMP_BEAD + 1 - J_MIN, min(len(p) for p in [base, *runs]) - 1 - PAIR_LIFE)
        d = self.pair_step()
        rho0 = residual((), base[:last + 1])
        rho = [residual(bump, peaks[:last + 1]) for bump, peaks in zip(self.pair_bumps(), runs)]
        out = []
        for gap in range(J_MAX - J_MIN + 1):
            up, down = rho[2 * gap], rho[2 * gap + 1]
            for m in sorted(set(up) & set(down) & set(rho0)):
                j = BUMP_BEAD + 1 - m
                if J_MIN <= j and j + gap <= J_MAX:
                    out.append(((j, j + gap), math.log(base[m - 1]), (up[m] + down[m] - 2.0 * rho0[m]) / d ** 2))
        return out

    def _bumped_set(self, lat: int, bumps: list, kind: str) -> list[list[float]]:
        """Peaks of the runs with ``bumps`` at lattice point ``lat``, through the on-disk cache as one entry: one
        write per lattice point, not one per run (each write is synced to disk)."""
        spec = self.table.spec
        key = f"{spec.key(lat)}|{kind}|" + ";".join(
            ",".join(f"fp+{b}:{name or 'R'}:{x!r}" for b, x, name in bump) for bump in bumps)
        hit = cache.load(NAMESPACE, key)
        if (isinstance(hit, list) and len(hit) == len(bumps)
                and all(isinstance(p, list) and all(isinstance(v, float) for v in p) for p in hit)):
            return hit
        peaks = [segment_peaks(replace(spec, bump=bump), lattice_amplitude(lat)) for bump in bumps]
        cache.store(NAMESPACE, key, peaks)
        return peaks


def _sorted(points: list) -> tuple[np.ndarray, np.ndarray]:
    points = sorted(points)
    return np.array([a for a, _ in points]), np.array([b for _, b in points])
