"""Energy- and momentum-balance reduced models (beyond the paper), derived like Eqs. 23 and 30.

The travelling wave of scale A (delta_j = A S(A^s t - j), s = (n - 1)/2, Eqs. 4, 7) moves bead 0
as x(t) = A X(tau), x'(t) = A^(1+s) X'(tau), tau = A^s t, with

    X(tau) = sum_{k >= 0} S(tau - k)        (x_i = sum_{k >= i} delta_k)

X rises from 0 to D = int S dtau (sum_m S(m + theta) = D for every theta: summing Eq. 4 over m
gives a periodic function with zero second derivative). The unperturbed chain conserves

    E = sum x'^2/2 + sum delta^(n+1)/(n+1) = E_1 A^(n+1),  E_1 = K_1 + V_1,
        K_1 = int X'^2/2 dtau,  V_1 = int S_+^(n+1)/(n+1) dtau
    p = sum x'                            = p_1 A^(1+s),  p_1 = int X' dtau (= D)

(a lattice sum at fixed time equals the time integral because the sum is constant in time).
When the wave passes a perturbed bead, eps R(u, v) = eps sum c_ab u^a v^b does

    work     W(A) = eps int R x' dt = eps sum c_ab A^(a + (1+s)(b+1) - s) w_ab,  w_ab = int X^a X'^(b+1) dtau
    impulse  J(A) = eps int R dt    = eps sum c_ab A^(a + (1+s) b - s)     j_ab,  j_ab = int X^a X'^b dtau

Energy model: the map E_1 A_i^(n+1) = E_1 A_{i-1}^(n+1) + W(A_{i-1}) (bead i, between contacts i-1
and i) and the law E_1 dB/di = eps sum_p C_p B^p, B = A^(n+1); momentum model likewise with p_1,
J and B = A^(1+s). A term without v (a foundation term c u^a) makes the impulse diverge (the bead
ends displaced by A D and the force keeps acting): the momentum model refuses such R.

Profiles: every integral is over |tau| <= L with the profile truncated to |tau| <= L,
L = ceil(tail of the exact profile) + 1 (7 for n = 3/2). For the exact profile this is exact to
1e-15; the Pade form (Eq. 5) decays algebraically and its sum_m S(m + theta) is not constant, so
X' never returns to zero and the window is part of its definition. Constants are computed with
mpmath.quad on unit sub-intervals and cached on disk like the map's (derive/cache.py).

The constants are :mod:`.balance_constants`, the expansion of R :mod:`.balance_expansion`, the laws
:mod:`.balance_law`; this module derives a model from them and renders it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import sympy

from .budget import Budget, check_max_seconds
from .balance_constants import WAVE_NAMES, BalanceError, balance_constants, check_model, integral_name, window
from .balance_expansion import A, BalanceExpansion, BalanceTerm, balance_expand
from .balance_law import B, EPS, K_SYMBOLS, BalanceLaw, balance_law, balance_site_law
from .longwave import LAW_RATE, check_law_inputs, law_data, law_lines, rate_latex, rate_symbol
from .perturbation import Perturbation, param_data
from .profile import check_exponent, check_profile_kind, get_profile
from .provenance import provenance
from .site_law import SiteLaw
from .sources import BALANCE_METHOD, DEFAULT_DPS
from .sources import BALANCE_MODELS as MODELS

__all__ = [
    "A", "B", "BALANCE_METHOD", "EPS", "K_SYMBOLS", "MODELS", "WAVE_NAMES", "BalanceDerivation", "BalanceError",
    "BalanceExpansion", "BalanceLaw", "BalanceTerm", "balance_constants", "balance_expand", "balance_law",
    "balance_site_law", "check_model", "derive_balance", "integral_name", "json_header", "map_equation",
    "model_title", "to_json", "to_latex", "to_text", "window",
]


@dataclass(frozen=True)
class BalanceDerivation:
    """A balance model derived for one perturbation, with the choices that produced it."""

    perturbation: Perturbation
    model: str
    n: float
    profile: str
    dps: int
    window: int
    S0: float
    expansion: BalanceExpansion
    constants: dict
    errors: dict
    law: BalanceLaw | SiteLaw | None
    law_note: str
    A0: float | None = None
    i0: float = 0.0
    timings_s: dict = field(default_factory=dict)

    @property
    def K(self) -> float:
        """E_1 (energy) or p_1 (momentum)."""
        c = self.constants
        return c["K1"] + c["V1"] if self.model == "energy" else c["p1"]


def model_title(model: str) -> str:
    return {
        "energy": "energy balance: E(A_i) = E(A_{i-1}) + W(A_{i-1}), E = E_1 A^(n+1), W = eps int R x' dt",
        "momentum": "momentum balance: p(A_i) = p(A_{i-1}) + J(A_{i-1}), p = p_1 A^(1+s), J = eps int R dt",
    }[model]


def derive_balance(
    pert: Perturbation,
    model: str = "energy",
    n: float = 1.5,
    profile: str = "exact",
    A0_value: float | None = None,
    i0: float = 0.0,
    dps: int | None = None,
    sympy_seconds: float = 2.0,
    max_seconds: float | None = None,
    progress=None,
) -> BalanceDerivation:
    """Derive the energy- or momentum-balance map and law for ``pert`` (module docstring)."""
    t0 = time.perf_counter()
    A0_value, i0, sympy_seconds = check_law_inputs(A0_value, i0, sympy_seconds, BalanceError)
    budget = Budget(check_max_seconds(max_seconds, BalanceError), progress)  # derive/budget.py
    model = check_model(model)
    n = check_exponent(n)
    profile = check_profile_kind(profile)
    ex = balance_expand(pert.R, n, model, pert.site_dependent)
    names = list(ex.wave_names) + ["D"] + list(ex.integrals())
    budget.check("the expansion")
    consts = balance_constants(names, n=n, profile=profile, dps=dps, budget=budget)
    sympy_seconds = min(sympy_seconds, budget.remaining())
    values = {k: c.value for k, c in consts.items()}
    errors = {k: c.error for k, c in consts.items()}
    t1 = time.perf_counter()
    law, note = None, ""
    try:
        if ex.uniform:
            law = balance_law(ex, values, pert.scalar_params(), float(pert.eps), sympy_seconds)
        else:
            law = balance_site_law(ex, pert, values, sympy_seconds)
    except BalanceError as exc:
        note = str(exc)
    budget.check("the law")
    t2 = time.perf_counter()
    return BalanceDerivation(
        perturbation=pert, model=model, n=n, profile=profile,
        dps=int(dps if dps is not None else DEFAULT_DPS[profile]), window=window(n),
        S0=get_profile(profile, n).S0, expansion=ex, constants=values, errors=errors, law=law, law_note=note,
        A0=A0_value, i0=i0, timings_s={"integrals": t1 - t0, "law": t2 - t1, "total": t2 - t0},
    )


# ------------------------------------------------------------------------- rendering
def map_equation(d: BalanceDerivation, numeric: bool = False) -> sympy.Eq:
    """K A_i^Q = K A_{i-1}^Q + eps sum c A_{i-1}^power integral (bead i's parameters)."""
    a_prev, a_i = sympy.symbols("A_{i-1} A_i", positive=True)
    K = sympy.Float(d.K, 15) if numeric else K_SYMBOLS[d.model]
    e = sympy.Float(d.perturbation.eps, 15) if numeric else EPS
    rate = d.expansion.rate(a_prev, d.constants if numeric else None)
    return sympy.Eq(K * a_i**d.expansion.Q, K * a_prev**d.expansion.Q + e * rate)


def json_header(model: str, pert: Perturbation) -> dict:
    """The first fields of every derivation's JSON (map or balance model): the model, provenance and
    the perturbation (expression, R, eps, parameters)."""
    header = {
        "model": model,
        "provenance": provenance(),
        "expression": pert.text,
        "R": str(pert.R),
        "eps": pert.eps,
        "params": {k: param_data(v) for k, v in pert.params.items()},
    }
    if pert.free_parameters:  # parameters left symbolic (Python API only)
        header["free_parameters"] = list(pert.free_parameters)
    return header


def to_json(d: BalanceDerivation) -> dict:
    """The balance derivation as JSON-serialisable data; ``model`` names it."""
    law = d.law
    if isinstance(law, SiteLaw):
        law_json = law.data()
    else:
        law_json = law_data(law, law.Q, ("K", law.K), d.A0, d.i0) if law is not None else None
    c = d.constants
    wave = ({"E1": d.K, "K1": c["K1"], "V1": c["V1"], "kinetic_fraction": c["K1"] / d.K} if d.model == "energy"
            else {"p1": c["p1"]})
    return {
        **json_header(d.model, d.perturbation),
        "title": model_title(d.model),
        "n": d.n,
        "profile": d.profile,
        "dps": d.dps,
        "window_L": d.window,
        "S0": d.S0,
        "D": c["D"],
        "wave": wave,
        "Q": str(d.expansion.Q),
        "constant_errors": d.errors,
        "terms": [{"exponents": list(t.exponents), "monomial": str(t.monomial), "coefficient": str(t.coefficient),
                   "integral": t.integral, "integral_value": c[t.integral], "power_of_A": str(t.power)}
                  for t in d.expansion.terms],
        "site_dependent": list(d.expansion.site_dependent),
        "map": {"equation": str(map_equation(d)), "equation_numeric": str(map_equation(d, numeric=True))},
        "law": law_json,
        "law_note": d.law_note or None,
        "timings_s": {k: round(v, 6) for k, v in d.timings_s.items()},
    }


def to_text(d: BalanceDerivation) -> str:
    """A readable report of the balance derivation."""
    c = d.constants
    ex = d.expansion
    kname = "E_1" if d.model == "energy" else "p_1"
    what = "work W/eps = int R x' dt" if d.model == "energy" else "impulse J/eps = int R dt"
    integ = "int X^a X'^(b+1) dtau" if d.model == "energy" else "int X^a X'^b dtau"
    lines = [
        f"Model: {model_title(d.model)}",
        f"R(u, v) = {d.perturbation.R}    eps = {d.perturbation.eps:g}    n = {d.n:g}    profile = {d.profile}",
        f"S(0) = {d.S0:.12g}; bead motion X(tau) = sum_(k>=0) S(tau - k), D = int S = {c['D']:.12g}; "
        f"integrals over |tau| <= {d.window}, mpmath dps {d.dps}",
    ]
    if d.model == "energy":
        lines.append(f"E_1 = K_1 + V_1 = {c['K1']:.12g} + {c['V1']:.12g} = {d.K:.12g}  "
                     f"(kinetic fraction {c['K1'] / d.K:.10g}; virial theorem: (n+1)/(n+3) = {(d.n + 1) / (d.n + 3):.10g})")
    else:
        lines.append(f"p_1 = int X' dtau = {c['p1']:.12g}")
    lines += ["", f"Terms of the {what} (monomial -> coefficient x {integ} x A^power):"]
    for t in ex.terms:
        lines.append(f"    {str(t.monomial):14s} {str(t.coefficient):>14s} x {t.integral} (= {c[t.integral]:.12g}) x A^({t.power})")
    lines += ["", "Map (bead i takes contact i-1 to contact i):", f"  {map_equation(d)}", f"  {map_equation(d, numeric=True)}", ""]
    law = d.law
    if law is None:
        lines.append(f"Law: not available ({d.law_note})")
    elif isinstance(law, SiteLaw):
        lines += law.lines(f"Law, B = A^({law.Q}), bead i + 1/2 at contact index i (R varies along the chain):")
    else:
        lines += law_lines(law, f"Law, B = A^({law.Q}):", kname, d.A0, d.i0,
                           constant_reason="no work on the wave")
    return "\n".join(lines)


def to_latex(d: BalanceDerivation) -> str:
    """The balance map, ODE and law in LaTeX."""
    names = {sympy.Symbol(t.integral, real=True): t.integral[0] + "_{" + t.integral[2:].replace("_", ",") + "}"
             for t in d.expansion.terms}
    lx = lambda e: sympy.latex(e, symbol_names=names)  # noqa: E731
    out = [rf"% pulsemap derivation, model: {d.model} balance; R = {d.perturbation.R}", lx(map_equation(d))]
    if d.law is not None:
        out.append(lx(d.law.ode()))
        if d.law.law is not None:
            out.append(rf"A(i) = {lx(d.law.law.xreplace({LAW_RATE: rate_symbol(d.law)}))}")
            out.append(rate_latex(d.law, K_SYMBOLS[d.model], lx))
    return "\n".join(out)
