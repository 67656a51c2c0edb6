"""From a perturbation R to the map (Eq. 23), the long-wave law (Eq. 30) and Eq. 41, in one call.

``derive_all`` runs the pipeline expression -> expansion -> integrals (only those that occur)
-> map -> law -> stationary equation and returns a :class:`Derivation`; ``to_json``,
``to_text`` and ``to_latex`` render it. The JSON is described in docs/design.rst ("The derivation").
``derive_model`` also offers the energy- and momentum-balance models (derive/balance.py); the
renderers accept either kind of derivation and name the model.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import sympy

from .errors import PulsemapError
from . import balance
from .amplitude_map import EPS, F_SYMBOLS, AmplitudeMap, check_variant, integral_symbol, latex_names
from .expansion import Expansion, expand
from .integrals import F_NAMES, constants
from .budget import Budget, DeriveTimeout, check_max_seconds
from .longwave import (LAW_RATE, A0, I, I0, LongwaveError, LongwaveLaw, check_law_inputs, law_data, law_lines,
                       longwave_law, needs_values, rate_latex, rate_symbol)
from .perturbation import Perturbation
from .profile import check_exponent, check_profile_kind, get_profile
from .site_law import SiteLaw, coefficient_of_i, site_law
from .sources import DEFAULT_DPS
from .stationary import Stationary, StationaryError, multiplier_1d, stationary


class DerivationError(PulsemapError):
    """The derivation cannot proceed as asked."""


@dataclass(frozen=True)
class Derivation:
    """Everything derived for one perturbation, with the choices that produced it."""

    perturbation: Perturbation
    n: float
    profile: str
    variant: str
    dps: int
    S0: float
    profile_accuracy: float
    expansion: Expansion
    constants: dict
    errors: dict
    amap: AmplitudeMap
    longwave: LongwaveLaw | SiteLaw | None
    longwave_note: str
    stationary: Stationary | None
    stationary_note: str
    A0: float | None = None
    i0: float = 0.0
    timings_s: dict = field(default_factory=dict)
    sympy_seconds: float = 2.0  # wall-clock bound on sympy's closed-form law (decides kind implicit/quadrature)


def derive_all(
    pert: Perturbation,
    n: float = 1.5,
    profile: str = "exact",
    variant: str = "paper",
    fold: str | None = None,
    A0_value: float | None = None,
    i0: float = 0.0,
    dps: int | None = None,
    sympy_seconds: float = 2.0,
    max_seconds: float | None = None,
    progress: Callable[[str], None] | None = None,
) -> Derivation:
    """Derive the map, the long-wave law and the stationary equation for ``pert`` (Eqs. 9-41).

    ``max_seconds`` bounds the whole derivation (DeriveTimeout past it; integrals done so far stay
    cached); ``progress`` receives one-line progress reports ("derive: integrals 120/1089, 14 s").
    """
    times: dict[str, float] = {}
    t0 = time.perf_counter()
    A0_value, i0, sympy_seconds = check_law_inputs(A0_value, i0, sympy_seconds, DerivationError)
    budget = Budget(check_max_seconds(max_seconds, DerivationError), progress)
    n = check_exponent(n)
    profile = check_profile_kind(profile)
    variant = check_variant(variant)
    site = pert.site_dependent
    ex = expand(pert.R, n, site)
    times["expansion"] = time.perf_counter() - t0
    budget.check("the expansion")

    t1 = time.perf_counter()
    names = list(F_NAMES) + list(ex.integrals())
    consts = constants(names, n=n, profile=profile, dps=dps, budget=budget)
    values = {k: c.value for k, c in consts.items()}
    errors = {k: c.error for k, c in consts.items()}
    prof = get_profile(profile, n)
    times["integrals"] = time.perf_counter() - t1

    t2 = time.perf_counter()
    scalars = pert.scalar_values()
    amap = AmplitudeMap(ex.n, variant, ex, values, scalars)
    law, law_note = None, ""
    seconds = min(sympy_seconds, budget.remaining())
    try:
        if pert.is_uniform:
            law = longwave_law(amap, float(pert.eps), seconds=seconds)
        else:
            law = longwave_site_law(amap, pert, seconds)
    except LongwaveError as exc:
        law_note = str(exc)
    times["longwave"] = time.perf_counter() - t2
    budget.check("the long-wave law")

    t3 = time.perf_counter()
    stat, stat_note = None, ""
    if site:
        stat_note = "Eq. 41 needs a uniform perturbation (site-dependent parameters: " + ", ".join(site) + ")"
        if fold:
            raise DerivationError(f"--fold {fold}: the perturbation is site-dependent, Eq. 41 needs uniform R")
    else:
        try:
            stat = stationary(amap, scalars, prof.S0, fold=fold)
        except StationaryError as exc:
            if fold:
                raise
            stat_note = str(exc)
    times["stationary"] = time.perf_counter() - t3
    budget.check("the stationary equation")
    times["total"] = time.perf_counter() - t0
    return Derivation(
        perturbation=pert,
        n=n,
        profile=profile,
        variant=variant,
        dps=dps if dps is not None else DEFAULT_DPS[profile],
        S0=prof.S0,
        profile_accuracy=prof.accuracy,
        expansion=ex,
        constants=values,
        errors=errors,
        amap=amap,
        longwave=law,
        longwave_note=law_note,
        stationary=stat,
        stationary_note=stat_note,
        A0=A0_value,
        i0=i0,
        timings_s=times,
        sympy_seconds=sympy_seconds,
    )


def longwave_site_law(amap: AmplitudeMap, pert: Perturbation, seconds: float = 2.0) -> SiteLaw:
    """Eq. 30 for a site-dependent R: (f1 - f3) dB/di = eps sum_p C_p(i) B^p, the first map equation of
    contact i with bead i + m's parameters at i + m (derive/site_law.py)."""
    ints = {integral_symbol(k): sympy.Float(v, 17) for k, v in amap.constants.items() if not k.startswith("f")}
    groups: dict = {}
    for pt in amap.power_terms(1, numeric=False):
        c = coefficient_of_i(pt.coefficient.xreplace(ints), pert, "longwave")
        groups[pt.power / amap.P] = groups.get(pt.power / amap.P, sympy.Integer(0)) + c
    f13 = float(amap.constants["f1"] - amap.constants["f3"])
    return site_law("longwave", amap.P, "(f1 - f3)", f13, float(pert.eps),
                    {p: sympy.expand(c) for p, c in groups.items()}, seconds)


#: The models ``derive_model`` offers: the paper's map (with its law and Eq. 41) and the balances.
MODELS = ("map",) + balance.MODELS


def derive_model(pert: Perturbation, model: str = "map", **kw) -> "Derivation | balance.BalanceDerivation":
    """``derive_all`` for model "map"; ``balance.derive_balance`` for "energy" and "momentum".

    Map-only options (variant, fold) are refused for a balance model rather than ignored.
    """
    if model == "map":
        return derive_all(pert, **kw)
    if model not in MODELS:
        raise DerivationError(f"unknown model {model!r}: choose one of {', '.join(MODELS)}")
    for option in ("variant", "fold"):
        if kw.pop(option, None) is not None:
            raise DerivationError(f"--{option} applies to the map only, not to the {model} balance: drop it or use --model map")
    return balance.derive_balance(pert, model, **kw)


# ------------------------------------------------------------------------- rendering
def _law_data(d: Derivation) -> dict | None:
    law = d.longwave
    if law is None:
        return None
    if isinstance(law, SiteLaw):
        return law.data()
    return law_data(law, law.P, ("f1_minus_f3", law.f1_minus_f3), d.A0, d.i0)


def _multipliers(d: Derivation) -> list[float]:
    """The 1d map's multiplier at each root of Eq. 41 (stationary.multiplier_1d)."""
    st = d.stationary
    return [multiplier_1d(d.amap, st.numeric, r, float(d.perturbation.eps)) for r in st.roots]


def to_json(d: Derivation) -> dict:
    """The derivation as JSON-serialisable data (docs/design.rst, "The derivation")."""
    if isinstance(d, balance.BalanceDerivation):
        return balance.to_json(d)
    pert = d.perturbation
    st = d.stationary
    stationary_data = None
    if st is not None:
        stationary_data = {
            "equation": str(st.equation) + " = 0",
            "equation_numeric": str(st.numeric) + " = 0",
            "roots": [{"A": r, "peak": r * d.S0, "multiplier_1d": m, "stable": bool(abs(m) < 1)}
                      for r, m in zip(st.roots, _multipliers(d))],
            "multiplier": "dA_i/dA_(i-1) of the 1d map at the root (its fixed points are the roots of Eq. 41)",
        }
        if st.missing:
            stationary_data["roots_need_values_for"] = list(st.missing)
        if st.fold is not None:
            f = st.fold
            stationary_data["fold"] = {"param": f.param, "value": f.value, "A": f.A, "peak": f.peak, "kind": f.kind}
            stationary_data["folds"] = [
                {"param": x.param, "value": x.value, "A": x.A, "peak": x.peak, "kind": x.kind} for x in st.folds
            ]
    return {
        **balance.json_header("map", pert),
        "n": d.n,
        "profile": d.profile,
        "variant": d.variant,
        "dps": d.dps,
        "sympy_seconds": d.sympy_seconds,
        "profile_accuracy": d.profile_accuracy,
        "S0": d.S0,
        **{k: d.constants[k] for k in F_NAMES},
        "constant_errors": d.errors,
        "g_i": str(d.expansion.g1),
        "g_ip1": str(d.expansion.g2),
        "monomials": [
            {
                "equation": t.equation,
                "exponents": list(t.exponents),
                "monomial": t.monomial_text,
                "coefficient": str(t.coefficient),
                "integral": t.integral,
                "integral_value": d.constants[t.integral],
                "power_of_A": str(t.power),
            }
            for t in d.expansion.terms
        ],
        "site_dependent": list(d.expansion.site_dependent),
        "map": {
            **d.amap.as_data(),
            "equations": [str(e) + " = 0" for e in d.amap.equations()],
            "equations_numeric": [str(e) + " = 0" for e in d.amap.equations(numeric=True)],
        },
        "longwave": _law_data(d),
        "longwave_note": d.longwave_note or None,
        "stationary": stationary_data,
        "stationary_note": d.stationary_note or None,
        "timings_s": {k: round(v, 6) for k, v in d.timings_s.items()},
    }


def to_text(d: Derivation) -> str:
    """A readable report of the derivation."""
    if isinstance(d, balance.BalanceDerivation):
        return balance.to_text(d)
    pert = d.perturbation
    lines = [
        f"Model: map (paper Eq. 23, variant '{d.variant}'), long-wave law (Eq. 30), stationary shocks (Eq. 41)",
        f"R(u, v) = {pert.R}    eps = {pert.eps:g}    n = {d.n:g}    profile = {d.profile}    map variant = {d.variant}",
        f"S(0) = {d.S0:.12g}; constants with mpmath dps {d.dps} (profile accuracy {d.profile_accuracy:.1e})",
        "",
        "Expansion (Eqs. 9, 12): delta_i, delta_ip1 are the contact strains, v_i, v_ip1 their rates",
        f"  g_i     = {d.expansion.g1}",
        f"  g_(i+1) = {d.expansion.g2}",
        "  monomial -> coefficient x integral x A^power:",
    ]
    for t in d.expansion.terms:
        amp = "A_i" if t.equation == 1 else "A_(i+1)"
        lines.append(
            f"    [eq {t.equation}] {t.monomial_text:28s} {str(t.coefficient):>12s} x {t.integral} "
            f"(= {d.constants[t.integral]:.12g}) x {amp}^({t.power})"
        )
    lines += ["", f"Amplitude map (Eq. 23, variant '{d.variant}'):"]
    for e, en in zip(d.amap.equations(), d.amap.equations(numeric=True)):
        lines.append(f"  0 = {e}")
        lines.append(f"    = {en}")
    lines.append("")
    if isinstance(d.longwave, SiteLaw):
        lines += d.longwave.lines(f"Long-wave ODE (Eq. 30), B = A^({d.longwave.Q}), "
                                  "parameters of bead i + m at i + m (R varies along the chain):")
    elif d.longwave is not None:
        lines += law_lines(d.longwave, f"Long-wave ODE (Eq. 30), B = A^({d.longwave.P}):", "(f1 - f3)",
                           d.A0, d.i0, cite="Eq. 31a ")
    else:
        lines.append(f"Long-wave law: not available ({d.longwave_note})")
    lines.append("")
    if d.stationary is not None:
        st = d.stationary
        lines.append("Stationary shocks (Eq. 41):")
        lines.append(f"  0 = {st.equation}")
        lines.append(f"    = {st.numeric}")
        if st.missing:
            lines.append("  roots: " + needs_values("the roots of Eq. 41", st.missing))
        elif st.roots:
            lines.append(f"  multiplier: dA_i/dA_(i-1) of the 1d map (A_(i+1) -> A_i in Eq. 23, whose fixed points "
                         f"are exactly these roots) at eps = {d.perturbation.eps:g}; stable when |multiplier| < 1")
            for r, m in zip(st.roots, _multipliers(d)):
                lines.append(f"  root A = {r:.12g}   peak A S(0) = {r * d.S0:.12g}   multiplier {m:.10g}: "
                             f"{'stable' if abs(m) < 1 else 'unstable'}")
        else:
            lines.append("  no positive root")
        if st.fold is not None:
            f = st.fold
            lines.append(
                f"  saddle-node in {f.param}: {f.param} = {f.value:.10g} at A = {f.A:.10g} "
                f"(peak {f.peak:.10g}); roots exist for {f.param} {'above' if f.kind == 'minimum' else 'below'} it"
            )
    else:
        lines.append(f"Stationary shocks: not available ({d.stationary_note})")
    return "\n".join(lines)


def to_latex(d: Derivation) -> str:
    """The map, the long-wave ODE and law, and Eq. 41 in LaTeX."""
    if isinstance(d, balance.BalanceDerivation):
        return balance.to_latex(d)
    names = latex_names(list(d.constants))
    lx = lambda e: sympy.latex(e, symbol_names=names)  # noqa: E731
    out = [r"% pulsemap derivation, model: map (Eq. 23); R = " + str(d.perturbation.R)]
    for k, e in enumerate(d.amap.equations(), 1):
        out.append(rf"0 = {lx(e)} \tag{{23.{k}}}")
    if d.longwave is not None:
        out.append(lx(d.longwave.ode()))
        if d.longwave.law is not None:
            out.append(rf"A(i) = {lx(d.longwave.law.xreplace({LAW_RATE: rate_symbol(d.longwave)}))}")
            out.append(rate_latex(d.longwave, F_SYMBOLS["f1"] - F_SYMBOLS["f3"], lx))
    if d.stationary is not None:
        out.append(rf"0 = {lx(d.stationary.equation)} \tag{{41}}")
    return "\n".join(out)


__all__ = ["Derivation", "DerivationError", "DeriveTimeout", "MODELS", "derive_all", "derive_model", "to_json", "to_text", "to_latex", "A0", "I", "I0", "EPS"]
