"""Segment runs and the tables of the relaxed transfer map, cached on disk.

A canonical segment run (``segment_peaks``) launches the exact solitary wave of amplitude A
(solvers/chain/launch.py) on contact c = launch.min_centre(n) of a chain perturbed from bead
c + GAP on, and records the leading-edge peaks P_0 (contact c + GAP - 1, the pulse entering the
perturbed region bare, as at the scenes' contact first_perturbed - 1) through P_CONTACTS.

A ``SegmentTable`` holds such runs on a lattice of launch amplitudes A_j = 2^(j / LATTICE) and
turns them into two interpolants (natural log of the per-contact ratio r = P_{k+1}/P_k):

* onset: for k = 1..ONSET (CONTACT_GEOMETRY for a contact law), log(P_k / P_{k-1}) as a function of log P_0 (a cubic spline across
  the lattice): the memory of the bare entry, read off runs that enter exactly like a scene;
* bulk: log(P_{k+1}/P_k) for k >= ONSET as a function of log P_k, pooled over all runs (a
  smoothing spline, GCV): the relaxed map P_{k+1} = F(P_k), valid once the pulse's shape is
  slaved to its amplitude.

Each run is cached by a key naming everything it depends on (R, parameters, eps, n, lattice
point, geometry, tolerances, engine), so a table grows run by run and is shared by every scene
that needs the same runs (pulsemap.symbolic.cache, namespace "relaxed").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
import numpy as np

from pulsemap.symbolic import cache
from pulsemap.symbolic.errors import PulsemapError

NAMESPACE = "relaxed"
VERSION = 2
GAP = 6  # beads between the launch contact and the first perturbed bead (S < 1e-15 S(0) there)
CONTACTS = 20  # contacts recorded after the entry contact
ONSET = 5  # contacts after the entry read from the onset table; the bulk map from then on
#: (CONTACTS, ONSET) of a contact law's tables: a damped contact's pulse keeps reshaping for about ten contacts
#: after it enters, so a bulk map read from 5 contacts on decays too fast by a constant share per contact
#: (docs/contact.rst, "What runs them")
CONTACT_GEOMETRY = (40, 10)
LATTICE = 3  # lattice points per factor 2 in the launch amplitude
DEATH = 1e-3  # a segment stops when its peak falls below this fraction of P_0
MAX_RUNS = 80  # segment runs one table may hold (a bound on the build cost)
#: How far (in log P) below the bulk points the map is read where the pulses die (SegmentTable.dying_step):
#: the lattice samples the last step before a death about this finely, so its lowest point lies up to one spacing
#: above the lowest peak that still has a successor.
DYING_REACH = math.log(2.0) / LATTICE


@dataclass(frozen=True)
class SegmentSpec:
    """Everything a segment run depends on but the launch amplitude.

    ``R`` the perturbation text, ``params`` its scalar values, ``eps``, ``n``; DNS ``rtol`` (the
    engine and method are the ones ``simulate`` chooses for the force: the compiled engine, Rodas4
    where stiff, Coulomb friction's ramp included); the moving window is sized for
    ``window_accuracy``. atol is rtol/100 times the amplitude's scales. ``bump``: () for the uniform
    chain, or ((bead, delta, name), ...): on each bead first_perturbed + bead, R multiplied by
    1 + delta (name "") or parameter ``name`` raised by delta (the runs a response kernel is
    measured from, solvers/models/relaxed_kernel.py). ``contact``: () for the Hertz law, or the contact law's
    term as ((a, b, eps_c c), ...): eps_c c d^a w^b on every contact from the first perturbed bead's on.
    """

    R: str
    params: tuple[tuple[str, float], ...]
    eps: float
    n: float
    rtol: float = 1e-9
    window_accuracy: float = 1e-8
    bump: tuple = ()
    contact: tuple = ()

    @property
    def recorded(self) -> int:
        """Contacts a segment run records after its entry (CONTACTS; a contact law's: CONTACT_GEOMETRY)."""
        return CONTACT_GEOMETRY[0] if self.contact else CONTACTS

    @property
    def onset(self) -> int:
        """Contacts after the entry read from the onset table (ONSET; a contact law's: CONTACT_GEOMETRY)."""
        return CONTACT_GEOMETRY[1] if self.contact else ONSET

    def geometry(self) -> tuple[int, int, int]:
        """(launch contact, first perturbed bead, entry contact) of the segment runs."""
        from pulsemap.solvers.chain.launch import min_centre

        centre = min_centre(self.n)
        return centre, centre + GAP, centre + GAP - 1

    def key(self, j: int) -> str:
        prm = ",".join(f"{k}={v!r}" for k, v in self.params)
        centre, fp, entry = self.geometry()
        return (f"relaxed-segment|v{VERSION}|R={self.R}|params={prm}|eps={self.eps!r}|n={self.n!r}"
                f"|A=2^({j}/{LATTICE})|centre={centre}|fp={fp}|contacts={entry}..{entry + self.recorded}"
                f"|death={DEATH}|rtol={self.rtol!r}|atol=rtol/100*scale|dns=simulate-auto"
                f"|window={self.window_accuracy!r}:{self.window_rule()}"
                + ("|bump=" + ";".join(f"bead fp+{b}:{name or 'R'}:{d!r}" for b, d, name in self.bump)
                   if self.bump else "")
                + ("|contact=" + ";".join(f"{c!r}*d^{a!r}*w^{b!r}" for a, b, c in self.contact) if self.contact else ""))

    def window_rule(self) -> str:
        """The segment runs' window geometry (window.rule_for_accuracy: the cache key follows its calibration; a
        dissipative contact term adds window.damped_behind, whose constants the key names)."""
        from pulsemap.solvers.chain.window import (DAMPED_BEHIND, DAMPED_GROWTH, DAMPED_PER_DECADE, DAMPED_POWER,
                                                   rule_for_accuracy)

        rule = rule_for_accuracy(self.window_accuracy)
        damped = any(int(b) % 2 == 1 for _, b, _ in self.contact)
        return (f"behind={rule.behind},threshold={rule.threshold!r}"
                + (f",damped={DAMPED_BEHIND!r}*max(gamma^{DAMPED_POWER!r},gamma)*{DAMPED_GROWTH!r}^max(0,n-3/2)"
                   f"*(1+{DAMPED_PER_DECADE!r}*decades),threshold/max(1,gamma)^2" if damped else ""))


def lattice_amplitude(j: int) -> float:
    return 2.0 ** (j / LATTICE)


class SegmentRunError(PulsemapError, RuntimeError):
    """A segment run that ended for a reason other than its pulse (an integrator failure, a spent step
    budget or t_max): the table cannot read it as a pulse that died. A blow-up (the chain's energy
    growing without bound: an unstable R) ends the pulse's record like a death, as before."""


PULSE_ENDS = ("last contact peaked", "pulse died", "blow-up")  # ends of the pulse, not of the integrator


def segment_peaks(spec: SegmentSpec, amplitude: float) -> list[float]:
    """Peaks P_0.. of one canonical segment run (DNS with a moving window, no cache), on the engine and
    method ``simulate`` chooses for the force. SegmentRunError when the run ends other than by its
    last contact, its pulse's death or a blow-up."""
    from pulsemap.solvers.chain.dns import Integrator, simulate
    from pulsemap.solvers.chain.launch import Launch
    from pulsemap.solvers.chain.peaks import StopRules
    from pulsemap.solvers.chain.window import WindowSpec
    from pulsemap.solvers.models.chain_build import ChainSpec, build_chain

    names = tuple(k for k, _ in spec.params)
    centre, fp, entry = spec.geometry()
    beads = entry + spec.recorded + 12
    eps, values = np.full(beads, float(spec.eps)), dict(spec.params)
    for bead, delta, name in spec.bump:
        if name:
            values[name] = np.full(beads, values[name]) if np.ndim(values[name]) == 0 else values[name]
            values[name][fp - 1 + bead] += delta
        else:
            eps[fp - 1 + bead] *= 1.0 + delta
    scale = min(1.0, amplitude, amplitude ** ((spec.n + 1.0) / 2.0))
    chain = build_chain(ChainSpec(beads, spec.n, 1.0, spec.R, names, values, eps, fp, _contact(spec, beads, fp)),
                        keep=False, launch=Launch(float(amplitude), centre))
    res = simulate(chain, (entry, entry + spec.recorded),
                   integrator=Integrator(rtol=spec.rtol, atol=spec.rtol * 1e-2 * scale),
                   window=WindowSpec("auto", spec.window_accuracy), stop=StopRules(death_fraction=DEATH))
    if not res.stop_reason.startswith(PULSE_ENDS):
        raise SegmentRunError(f"segment run of R = {spec.R} (eps {spec.eps:g}) launched at amplitude {amplitude:.6g} "
                              f"ended early: {res.stop_reason} [{res.engine}: {res.engine_reason}]")
    out = []
    for p, alive in zip(res.peaks, res.alive):
        if not alive or not math.isfinite(p):
            break
        out.append(float(p))
    return out


def _contact(spec: SegmentSpec, beads: int, fp: int):
    """The segment chain's contact-law term as (exponents, coefficients over contacts 1..N-1); None: Hertz alone."""
    if not spec.contact:
        return None
    coef = np.zeros((len(spec.contact), beads - 1))
    coef[:, fp - 1:] = np.array([c for _, _, c in spec.contact])[:, None]
    return np.array([[a, b] for a, b, _ in spec.contact], float), coef


def cached_segment(spec: SegmentSpec, j: int) -> list[float]:
    """segment_peaks at lattice point j, through the on-disk cache."""
    key = spec.key(j)
    hit = cache.load(NAMESPACE, key)
    if isinstance(hit, list) and all(isinstance(p, float) for p in hit):
        return hit
    peaks = segment_peaks(spec, lattice_amplitude(j))
    cache.store(NAMESPACE, key, peaks)
    return peaks


@dataclass
class SegmentTable:
    """Segment runs on a contiguous lattice j_lo..j_hi and the onset and bulk interpolants."""

    spec: SegmentSpec
    runs: dict[int, list[float]] = field(default_factory=dict)
    _bulk: object | None = None
    _onset: list | None = None
    _range: tuple | None = None  # (log P lo, log P hi) of the bulk points, or () when too few
    closed: set = field(default_factory=set)  # "low"/"high": no relaxed pulse beyond the lattice's end

    # ------------------------------------------------------------ runs
    def add(self, j: int) -> list[float]:
        if j not in self.runs:
            self.runs[j] = cached_segment(self.spec, j)
            self._bulk = self._onset = self._range = None
        return self.runs[j]

    def span(self) -> tuple[int, int]:
        return min(self.runs), max(self.runs)

    def ending(self, log_p: float) -> str:
        """How the runs entering nearest exp(log_p) end: "blow up" when their peaks grow to the end of
        their record (the chain's energy runs away, a blow-up stops the run), else "die"."""
        records = [p for p in self.runs.values() if p]
        if not records:
            return "die"
        peaks = min(records, key=lambda p: abs(math.log(p[0]) - log_p))
        return "blow up" if len(peaks) > 1 and peaks[-1] > peaks[0] else "die"

    def ensure_entry(self, log_p0: float, margin: int = 3) -> None:
        """Runs whose entry peaks bracket exp(log_p0) with ``margin`` lattice points each side."""
        from pulsemap.symbolic.profile import exact_profile

        S0 = exact_profile(self.spec.n).S0
        j0 = int(math.floor((log_p0 - math.log(S0)) / math.log(2.0) * LATTICE))
        for j in range(j0 - margin, j0 + margin + 2):
            self.add(j)

    def cover(self, log_p: float) -> bool:
        """Add lattice runs until the bulk map's range holds log P = log_p (or ``dying_step``). False
        when it cannot: beyond the runs' range pulses die before they relax (the lattice's end is then
        closed), or the run budget MAX_RUNS is spent."""
        while True:
            rng = self.bulk_range()
            if rng is not None and rng[0] <= log_p <= rng[1]:
                return True
            side = "high" if rng is None or log_p > rng[1] else "low"
            if side in self.closed or len(self.runs) >= MAX_RUNS:
                return self.dying_step(log_p)
            if not self.runs:
                self.ensure_entry(log_p, margin=1)
                continue
            lo, hi = self.span()
            peaks = self.add(hi + 1 if side == "high" else lo - 1)
            if len(peaks) <= self.spec.onset + 1:
                self.closed.add(side)

    def dying_step(self, log_p: float) -> bool:
        """True when log_p lies within DYING_REACH below the bulk points and the pulses die there (the low
        end closed): a step the runs take just before their death, though no run's lattice point fell on
        it (a pulse that dies at a finite contact, as under Coulomb friction, takes one); the bulk map's
        fit is read there as it continues."""
        rng = self.bulk_range()
        return (rng is not None and "low" in self.closed and rng[0] - DYING_REACH <= log_p < rng[0]
                and self.ending(log_p) == "die")

    # ------------------------------------------------------------ data
    def bulk_points(self, runs: dict[int, list[float]] | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(log P_k, log P_{k+1}/P_k) for k >= the spec's onset over the runs, sorted by log P_k."""
        xs, ys = [], []
        onset = self.spec.onset
        for peaks in (self.runs if runs is None else runs).values():
            p = np.asarray(peaks)
            if len(p) > onset + 1:
                xs.append(np.log(p[onset:-1]))
                ys.append(np.log(p[onset + 1:] / p[onset:-1]))
        if not xs:
            return np.zeros(0), np.zeros(0)
        x, y = np.concatenate(xs), np.concatenate(ys)
        order = np.argsort(x)
        return x[order], y[order]

    def bulk_range(self) -> tuple[float, float] | None:
        if self._range is None:
            x, _ = self.bulk_points()
            self._range = (float(x[0]), float(x[-1])) if x.size >= 4 else ()
        return self._range or None

    def bulk(self):
        """log r(log P) of the relaxed map (smoothing spline through the pooled runs)."""
        if self._bulk is None:
            self._bulk = fit_bulk(*self.bulk_points())
        return self._bulk

    def onset(self) -> list:
        """For k = 1..the spec's onset: (log P_0 of the runs alive at k, log P_k/P_{k-1}, their cubic spline or None)."""
        from scipy.interpolate import CubicSpline

        if self._onset is None:
            out = []
            for k in range(1, self.spec.onset + 1):
                pts = sorted((math.log(p[0]), math.log(p[k] / p[k - 1])) for p in self.runs.values() if len(p) > k)
                x, y = np.array([a for a, _ in pts]), np.array([b for _, b in pts])
                out.append((x, y, CubicSpline(x, y) if x.size >= 4 else None))
            self._onset = out
        return self._onset

    def onset_ratios(self, log_p0: float) -> list[float]:
        """log ratios of contacts 1..ONSET after entry at P_0 (cubic in log P_0), up to the first contact
        the runs around P_0 do not reach (the pulse dies there within the onset) or where P_0 is off the
        lattice: fewer than ONSET then. Like the bulk map (dying_step), a step is read down to DYING_REACH
        below the lowest entry that takes it where the runs entering lower die before it: the pulse's
        last step."""
        out = []
        for x, _, spline in self.onset():
            dying = bool(x.size) and x[0] - DYING_REACH <= log_p0 < x[0] and self.ending(log_p0) == "die"
            if spline is None or not (x[0] <= log_p0 or dying) or log_p0 > x[-1]:
                break
            out.append(float(spline(log_p0)))
            if dying:
                break
        return out


BIN = math.log(2.0) / LATTICE / 4  # width in log P of the bins the bulk points are averaged over


def fit_bulk(x: np.ndarray, y: np.ndarray, cached: bool = True):
    """y(x) through the bulk points: means over bins of width BIN in x, then a smoothing spline
    (GCV; PCHIP if that is ill-posed), linear for 2-4 bins, constant for one. None: no points.
    ``cached``: the spline read from and stored in the on-disk cache (cached_smoothing_spline)."""
    from scipy.interpolate import PchipInterpolator

    if x.size == 0:
        return None
    edges = np.floor((x - x[0]) / BIN).astype(int)
    groups = np.unique(edges, return_inverse=True)[1]
    counts = np.bincount(groups)
    xb = np.bincount(groups, weights=x) / counts
    yb = np.bincount(groups, weights=y) / counts
    if xb.size == 1:
        value = float(yb[0])
        return lambda t: np.full(np.shape(t), value) if np.ndim(t) else value
    if xb.size < 5:
        return lambda t: np.interp(t, xb, yb)
    w = counts.astype(float)
    return (cached_smoothing_spline(xb, yb, w) if cached else _smoothing_spline(xb, yb, w)) or PchipInterpolator(xb, yb)


def cached_smoothing_spline(x: np.ndarray, y: np.ndarray, w: np.ndarray):
    """scipy's GCV smoothing spline through (x, y, w), its knots and coefficients cached on disk by a
    digest of the data and the scipy version (the cached spline is the same BSpline, bit for bit).
    None when the fit is ill-posed."""
    from scipy.interpolate import BSpline

    key = bulk_fit_key(x, y, w)
    hit = cache.load(NAMESPACE, key, _spline_problem)
    if hit is not None:
        return BSpline(np.array(hit["t"], float), np.array(hit["c"], float), int(hit["k"]))
    spline = _smoothing_spline(x, y, w)
    if spline is None:
        return None
    cache.store(NAMESPACE, key, {"t": spline.t.tolist(), "c": spline.c.tolist(), "k": int(spline.k)})
    return spline


def _smoothing_spline(x: np.ndarray, y: np.ndarray, w: np.ndarray):
    """scipy's make_smoothing_spline(x, y, w=w), bit for bit, its GCV search made fast (gcv_spline.py);
    None when the fit is ill-posed."""
    from pulsemap.solvers.models.gcv_spline import gcv_smoothing_spline

    try:
        return gcv_smoothing_spline(x, y, w)
    except (np.linalg.LinAlgError, ValueError):
        return None


def bulk_fit_key(x: np.ndarray, y: np.ndarray, w: np.ndarray) -> str:
    """The cache key of a bulk fit: a digest of its data and the scipy version that fits it."""
    import hashlib

    import scipy

    digest = hashlib.sha256(b"".join(np.ascontiguousarray(a, float).tobytes() for a in (x, y, w))).hexdigest()
    return f"relaxed-bulk-fit|v1|scipy={scipy.__version__}|n={x.size}|data={digest}"


def _spline_problem(value) -> str | None:
    if not (isinstance(value, dict) and isinstance(value.get("k"), int) and isinstance(value.get("t"), list)
            and isinstance(value.get("c"), list)):
        return "not a spline {t, c, k}"
    if not all(cache.finite_number(v) for v in value["t"] + value["c"]):
        return "non-finite knots or coefficients"
    t, k = value["t"], value["k"]
    if any(b < a for a, b in zip(t, t[1:])):
        return "knots out of order"
    if not 0 <= k <= 5 or len(t) < 2 * k + 2 or len(value["c"]) < len(t) - k - 1:
        return f"{len(t)} knots and {len(value['c'])} coefficients do not make a spline of degree {k}"
    return None


def leave_one_out(table: SegmentTable) -> float:
    """Largest |error| in log r when each run's bulk points are predicted from the other runs'
    fit, over the interior of the range: the bulk map's stated accuracy (interpolation plus the
    memory the relaxed map ignores plus DNS error). Cached on disk as one entry by a digest of the
    runs (the left-out fits are not stored one by one: each store is synced to disk)."""
    import hashlib

    import scipy

    data = ";".join(f"{j}:" + ",".join(repr(v) for v in p) for j, p in sorted(table.runs.items()))
    key = (f"relaxed-leave-one-out|v1|scipy={scipy.__version__}|onset={table.spec.onset}|bin={BIN!r}"
           f"|runs={hashlib.sha256(data.encode()).hexdigest()}")
    hit = cache.load(NAMESPACE, key, lambda v: None if cache.finite_number(v) and v >= 0 else "not a number >= 0")
    if hit is not None:
        return float(hit)
    worst = _leave_one_out(table)
    cache.store(NAMESPACE, key, worst)
    return worst


def _leave_one_out(table: SegmentTable) -> float:
    """leave_one_out computed: one bulk fit per left-out run with bulk points inside the others' range
    (a run without such points states nothing: its fit is skipped)."""
    worst = 0.0
    for j in list(table.runs):
        others = {i: p for i, p in table.runs.items() if i != j}
        xo, yo = table.bulk_points(others)
        xj, yj = table.bulk_points({j: table.runs[j]})
        if xj.size == 0 or xo.size == 0:
            continue
        inside = (xj >= xo[0]) & (xj <= xo[-1])
        if not np.any(inside):
            continue
        fit = fit_bulk(xo, yo, cached=False)
        if fit is not None:
            worst = max(worst, float(np.max(np.abs(fit(xj[inside]) - yj[inside]))))
    return worst
