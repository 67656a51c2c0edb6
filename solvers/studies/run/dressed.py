"""The dressed law (method ``dressed-law``) in a run: form it (studies/dressed.py), seed it, measure its error on
its own short DNS segments, evaluate it."""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from pulsemap.solvers.chain.force_table import monomial_text
from pulsemap.solvers.chain.launch import min_centre
from pulsemap.solvers.models.dressed import MeasuredError, evaluate_dressed_law
from pulsemap.solvers.studies.extent import on_contacts
from pulsemap.solvers.studies.run.state import RunState


def prepare_dressed(state: "RunState") -> tuple[object | None, str | None]:
    """(the dressed law for the scene's R, None), or (None, why it is refused)."""
    from pulsemap.symbolic.dressed import DressedError  # sympy: only when the dressed law is asked for
    from pulsemap.solvers.studies.dressed import dressed_law

    scene = state.scene
    why, law = None, None
    if state.choice.profile != "exact":
        why = "the dressed law uses the exact profile (its coefficients come from launched exact solitons)"
    else:
        t0 = time.perf_counter()
        try:
            law = dressed_law(scene.perturbation, scene.exponent, at_bead=float(scene.first_perturbed) - 0.5)
        except DressedError as exc:
            why = str(exc)
        state.timings["derive_dressed"] = time.perf_counter() - t0
    return law, why


def provenance(law, kind: str) -> list[str]:
    """Which coefficients of the law (``monomial:k2_over_k1``, ``monomial:onset_lag``, ``cross:j x l``) are
    ``kind`` ("derived" or "calibrated"); k1 is always derived (energy balance)."""
    out = []
    for t in law.terms:
        out += [f"{t.monomial}:{name}" for name, method in (("k2_over_k1", t.rho_method), ("onset_lag", t.lag_method))
                if method.startswith(kind)]
    return out + [f"cross:{ct.first} x {ct.second}" for ct in law.cross if ct.method.startswith(kind)]


SEED_SPAN = 12  # contacts of the scene's own chain past the seed: the kicked pulse's onset and a window after it
SETTLE = 12  # contacts a launched wave runs before it is read: its own onset has relaxed (docs/models.rst)
READ = 4  # contacts per window over which a residual rate is read (two windows per launched wave)
NODE_STEP = 0.25  # the largest change of ln A between two launched waves (between them the larger residual holds)
SEGMENT_RTOL = 1e-8  # the launched waves' tolerance: their residuals far below any that matters (docs/models.rst)


def rate_residual(coef, lnA, at) -> float:
    """True rate - law rate per contact over consecutive contacts: (ln A_last - ln A_first)/span minus the law's
    rate averaged along the true path (the coefficients at the contact indices ``at``). The average is the
    trapezoid's corrected by the trapezoid's own error on the law's path from the same start (its exact step
    minus its trapezoid): where the rate changes fast along the window that error rivals the residual."""
    from scipy.integrate import solve_ivp

    span = len(lnA) - 1
    step = (at[-1] - at[0]) / span

    def trapezoid(path):
        rates = [coef.rate(math.exp(v), at[0] + k * step) for k, v in enumerate(path)]
        return sum(rates) - (rates[0] + rates[-1]) / 2

    own = solve_ivp(lambda t, y: [coef.rate(math.exp(y[0]), at[0] + t * step)], (0.0, float(span)), [lnA[0]],
                    method="LSODA", rtol=1e-11, atol=1e-13, t_eval=np.arange(span + 1.0)).y[0]
    return ((lnA[-1] - lnA[0]) - trapezoid(lnA) + trapezoid(own) - (own[-1] - own[0])) / span


def _launch_amplitude(coef, lnA: float, at: float, contacts: float) -> float:
    """ln A to launch at so that the law (coefficients at ``at``) reaches ln A after ``contacts`` contacts."""
    from scipy.integrate import solve_ivp

    try:
        sol = solve_ivp(lambda i, y: [coef.rate(math.exp(y[0]), at)], (contacts, 0.0), [lnA], rtol=1e-8, atol=1e-10)
        back = float(sol.y[0, -1])
    except (OverflowError, ZeroDivisionError):
        return lnA
    # a march back that more than e^5-folds A left the law's range: keep the seed
    return back if sol.status == 0 and math.isfinite(back) and back < lnA + 5 else lnA


def _launched_peaks(coef, n: float, A: float, at: float) -> list:
    """Peaks of contacts first .. first + SETTLE + 2 READ (None past the pulse's death) of an exact wave of scale
    A launched at contact first - 8 into a chain whose beads >= first carry the law's monomials with their
    coefficients at contact index ``at`` (the compiled DNS; the force's code generated once per monomial set)."""
    from pulsemap.solvers.chain.dns import Integrator, simulate
    from pulsemap.solvers.chain.launch import Launch
    from pulsemap.solvers.models.chain_build import ChainSpec, build_chain

    from pulsemap.solvers.models.dressed import DressedEvalError

    if len(coef.monomials) != len(coef.c):  # without them the wave would be launched into a bare chain
        raise DressedEvalError(f"the law's {len(coef.c)} coefficients name {len(coef.monomials)} monomials: "
                               "give DressedCoefficients(monomials=...) to measure its accuracy on launched waves")
    centre = min_centre(n) + 1
    first = centre + 8  # the wave's own tail clear of the perturbed beads when it is launched
    last = first + SETTLE + 2 * READ
    beads = last + min_centre(n) + 2
    names = tuple(f"c{j}" for j in range(len(coef.monomials)))
    R = " + ".join(f"{name}*{monomial_text(a, b)}" for name, (a, b) in zip(names, coef.monomials))
    cs = coef.c if coef.c_of_i is None else [f(at) for f in coef.c_of_i]
    spec = ChainSpec(beads, n, 1.0, R if names else "0", names, dict(zip(names, cs)), 1.0, first)
    scale = min(1.0, A, A ** ((n + 1.0) / 2.0))
    res = simulate(build_chain(spec, keep=False, launch=Launch(float(A), centre)), (first, last),
                   integrator=Integrator(rtol=SEGMENT_RTOL, atol=SEGMENT_RTOL * 1e-2 * scale))
    out = on_contacts(range(first, last + 1), res.contacts, res.peaks, res.alive)
    dead = next((k for k, p in enumerate(out) if p is None), len(out))
    return out[:dead] + [None] * (len(out) - dead)


def _launched_residuals(coef, n: float, S0: float, lnA: float, at: float, ahead: float):
    """Rate residuals per contact in two consecutive windows of READ contacts: an exact wave launched into a
    uniform chain carrying the law's monomials with their coefficients at contact index ``at``, read after SETTLE
    contacts, launched where the law puts ln A at ``ahead`` contacts after SETTLE (a pulse that dies sooner: its
    last two windows of up to READ contacts, after at least one). ((mid ln A, residual) per window), or None where
    the pulse dies within 3 contacts."""
    start_lnA = _launch_amplitude(coef, lnA, at, SETTLE + ahead)
    peaks = _launched_peaks(coef, n, math.exp(start_lnA), at)
    live = next((k for k, p in enumerate(peaks) if p is None), len(peaks))
    read = READ if live > SETTLE + 2 * READ else min(READ, (live - 1) // 3)  # a dying pulse: what it has left
    if read < 1:
        return None
    start = SETTLE if live > SETTLE + 2 * READ else live - 1 - 2 * read
    lnP = [math.log(p / S0) for p in peaks[start:start + 2 * read + 1]]
    windows = (lnP[:read + 1], lnP[read:])
    return [((w[0] + w[-1]) / 2, rate_residual(coef, w, [at] * (read + 1))) for w in windows]


def measure_law_error(state: "RunState", coef, S0: float, path) -> MeasuredError | None:
    """The law's error measured on its own short DNS segments (models/dressed.py, ``MeasuredError``): the scene's
    chain cut after contact iL = i0 + SEED_SPAN (kicked as the scene is, same integrator), and exact waves launched
    so that their reading windows straddle amplitudes along the law's ``path`` (an evaluation without estimate) at
    most NODE_STEP apart in ln A. Each window's residual stands at the mid ln A it was read at, plus the
    difference of the wave's two windows (its spread: a transient not yet relaxed, a wake younger than a long
    chain's); inf below where a launched pulse was lost. The offset: the kicked chain's residual over its last
    READ contacts minus that of a wave launched to read its first window at the same amplitude. None where the
    law gives no value past the seed; no seed contacts where the chain's pulse is gone by i0 + 1, an inf residual
    past the contact where it dies within the seed segment."""
    from pulsemap.solvers.chain.dns import simulate
    from pulsemap.solvers.chain.window import window_accuracy_for
    from pulsemap.solvers.studies.extent import dns_integrator
    from pulsemap.solvers.studies.scene_chain import scene_chain

    scene, n = state.scene, float(state.scene.exponent)
    i0 = scene.first_perturbed - 1
    live = [(int(c), a) for c, a in zip(path.run.contacts, path.run.A) if a is not None and c > i0]
    if not live:
        return None
    iL = min(i0 + SEED_SPAN, live[-1][0])
    beads = iL + min_centre(n) + 2
    res = simulate(scene_chain(scene, beads), (i0, iL), integrator=dns_integrator(scene.dns))
    seg = []
    for c, p in zip(range(i0, iL + 1), on_contacts(range(i0, iL + 1), res.contacts, res.peaks)):
        if p is None or p <= 0:  # up to the last contact the chain's pulse reaches
            break
        seg.append((c, math.log(p / S0)))
    tol = window_accuracy_for(res.rtol, None)
    if len(seg) < 2:  # the chain's pulse is gone by the seed's next contact: nothing to measure the law on
        return MeasuredError((), (), tol, (), (), math.inf)
    if seg[-1][0] < iL:  # the chain's pulse died within the seed segment: no value past it
        return MeasuredError(tuple(float(c) for c, _ in seg[1:]), tuple(v for _, v in seg[1:]), tol, (seg[-1][1],),
                             (math.inf,), math.inf)
    window = seg[-1 - min(READ, iL - i0):]
    kicked = rate_residual(coef, [v for _, v in window], [float(c) for c, _ in window])
    nodes = [(seg[-1][1], float(iL))]
    for c, a in live:
        if c > iL and (abs(math.log(a) - nodes[-1][0]) >= NODE_STEP or c == live[-1][0]):
            nodes.append((math.log(a), float(c)))
    kicked_mid = (window[0][1] + window[-1][1]) / 2
    reads = [_launched_residuals(coef, n, S0, kicked_mid, float(iL), READ / 2)]  # window 1 on the kicked one's
    for lnA, at in nodes:  # the windows straddle ln A; past a lost pulse the estimate is inf anyway
        reads.append(_launched_residuals(coef, n, S0, lnA, at, READ) if reads[-1] is not None else None)
    at_, bound = [], []
    for target, w in zip([kicked_mid] + [lnA for lnA, _ in nodes], reads):
        if w is None:  # the pulse was lost: no residual known around the amplitude it was to be read at
            at_.append(target)
            bound.append(math.inf)
            continue
        (x1, r1), (x2, r2) = w
        at_ += [x1, x2]
        bound += [abs(r1) + abs(r1 - r2), abs(r2) + abs(r1 - r2)]
    offset = math.inf if reads[0] is None else abs(kicked - reads[0][0][1])
    return MeasuredError(tuple(float(c) for c, _ in seg[1:]), tuple(v for _, v in seg[1:]), tol, tuple(at_),
                         tuple(bound), offset)


def run_dressed(state: "RunState", name: str, law, seed_A: float, S0: float) -> dict:
    """Evaluate the dressed law from the seed A (contact first_perturbed - 1, converted with S0: peak = A S0)
    over the scene's contacts; its entry of the result."""
    from pulsemap.solvers.studies.dressed import coefficients, site_coefficient_functions

    scene, out = state.scene, state.out
    t0 = time.perf_counter()
    coef = coefficients(law)
    i0 = float(scene.first_perturbed - 1)
    if not scene.perturbation.is_uniform:  # c_j(i) along the chain (bead i + 1/2 at contact index i)
        coef = replace(coef, c_of_i=site_coefficient_functions(scene.perturbation, law, i0, float(scene.contacts[1])))
    path = evaluate_dressed_law(coef, S0, seed_A, i0, state.contacts)
    measured = measure_law_error(state, coef, S0, path)
    ev = evaluate_dressed_law(coef, S0, seed_A, i0, state.contacts, measured) if measured is not None else path
    run, beyond = ev.run, ev.beyond
    state.timings[name] = time.perf_counter() - t0
    out["peaks"][name] = on_contacts(state.contacts, run.contacts, run.peaks)
    given = [a for a in ev.accuracy if a is not None]
    info = {"profile": "exact", "status": run.status, "message": run.message,
            "ended_at": run.ended_at, "law_kind": run.law_kind, "beyond_validity_at": beyond,
            "accuracy": on_contacts(state.contacts, run.contacts, ev.accuracy),
            "note": (f"estimated accuracy +-{100 * max(given):.2g} % (largest over the values given)" if given
                     else f"no value: {run.message}"),
            "coefficients": {t.monomial: {"k1": t.k1, "k2_over_k1": t.rho, "onset_lag": t.lag}
                             for t in law.terms},
            "derived": provenance(law, "derived"), "calibrated": provenance(law, "calibrated")}
    if run.status != "ok":
        state.warnings.append(f"{name}: {run.message}")
    if beyond is not None and beyond <= state.contacts[-1]:
        state.warnings.append(f"{name}: from contact index {beyond:.4g} some |x_j| exceeds the two-term law's "
                              "calibrated validity bound (derive --model dressed prints it): the values given there "
                              "carry their measured estimate")
    return info
