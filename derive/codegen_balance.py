"""The generated energy- or momentum-balance module (derive/balance.py): map step and law.

Parameter arguments are named as in the map module (derive/codeprint.py); ``PARAMS`` lists the
user's parameter names, ``ARGS`` the (name, bead offset) of each argument after eps.
"""

from __future__ import annotations

import sympy

from .codeprint import code, const, measured, module, param_args, profile_peak, start, title
from .expression import parse_expression
from .sources import BalanceSource

_EPS = sympy.Symbol("eps", real=True)
_K = sympy.Symbol("K", real=True)


def generate_balance(source: BalanceSource) -> str:
    """The text of an energy- or momentum-balance module (derive/balance.py): map step and law.

    Raises BalanceError when the model is undefined for R (e.g. momentum with a foundation term).
    """
    from .balance import A as SYM_A
    from .balance import B as SYM_B
    from .balance import balance_constants, balance_expand, balance_law

    R = parse_expression(source.R, source.params)
    n = sympy.Rational(source.n)
    ex = balance_expand(R, n, source.model, source.site_dependent)
    names = list(ex.wave_names) + list(ex.integrals())
    consts = balance_constants(names, n=float(n), profile=source.profile, dps=source.dps)
    values = {k: measured(c.value, c.error) for k, c in consts.items()}
    args, described, param_names = param_args(source, ex.terms, (0,))
    ren: dict[sympy.Symbol, str] = {SYM_A: "A", SYM_B: "B", **param_names}
    for k in ex.integrals():
        ren[sympy.Symbol(k, real=True)] = k
    sig = ", ".join(["eps"] + args)
    kname = "E1" if source.model == "energy" else "p1"
    lines = start(source)
    lines.append(f"MODEL = {source.model!r}")
    lines.append(f"PARAMS = {tuple(dict.fromkeys(name for name, _ in described if name != 'i'))!r}")
    lines.append(f"ARGS = {tuple(described)!r}  # (parameter, bead offset) of each argument after eps; ('i', 0): bead index")
    lines.append(f"Q = {const(float(ex.Q))}  # the balanced quantity is K A^Q")
    lines.append(f"N_EXPONENT = {const(float(n))}")
    lines.append("")
    lines.append(f"# wave constants and profile integrals ({source.profile} profile, mpmath dps {source.dps}), to the digits they are accurate to")
    if source.model == "energy":
        lines.append(f"K1 = {const(values['K1'])}  # int X'^2/2: kinetic part of E_1")
        lines.append(f"V1 = {const(values['V1'])}  # int S^(n+1)/(n+1): contact part of E_1")
        lines.append("E1 = K1 + V1  # E = E1 A^(n+1)")
    else:
        lines.append(f"p1 = {const(values['p1'])}  # p = p1 A^(1+s)")
    lines.append(f"K = {kname}")
    for k in ex.integrals():
        lines.append(f"{k} = {const(values[k])}")
    lines.append(f"S0 = {const(profile_peak(source.profile, float(n)))}  # peak = A S(0), Eq. 32")
    lines.append("")
    rate = ex.rate(SYM_A)
    what = "W(A) = eps int R x' dt" if source.model == "energy" else "J(A) = eps int R dt"
    lines.append(f"def balance_rate(A, {sig}):")
    lines.append(f'    """{what} for one bead (its parameters). Parameters: {sig}."""')
    lines.append(f"    return eps * ({code(rate, ren)})")
    lines.append("")
    lines.append(f"def balance_step(a_prev, {sig}):")
    lines.append(
        '    """(A_i, base): K A_i^Q = K a_prev^Q + rate(a_prev) at bead i; base = A_i^Q, <= 0 means the '
        'pulse died (A_i is then 0)."""'
    )
    lines.append(f"    base = a_prev ** Q + balance_rate(a_prev, {sig}) / K")
    lines.append("    return numpy.where(base > 0, numpy.abs(base) ** (1.0 / Q), 0.0), base")
    lines.append("")
    lines.append(f"UNIFORM = {ex.uniform!r}")
    law = balance_law(ex, values, {}, 1.0, seconds=0) if ex.uniform else None  # eps enters below explicitly
    if law is not None and law.powers:
        lines.extend(_law_lines(law, ex, ren, sig, SYM_B))
    else:
        lines.append("LAW_KIND = None")
    return module(lines, title(f"{source.model.capitalize()}-balance model (derive/balance.py): map step and law", source), source)


def _law_lines(law, ex, ren: dict, sig: str, SYM_B: sympy.Symbol) -> list[str]:
    """law_rhs and (one power) law_closed as code lines."""
    rhs = _EPS / _K * sum((c * SYM_B**p for c, p in zip(law.symbolic_coefficients, law.powers)), sympy.Integer(0))
    lines = [f"LAW_KIND = {law.kind!r}",
             f"def law_rhs(B, {sig}):",
             f'    """dB/di = eps sum C_p B^p / K, B = A^Q. Parameters: {sig}."""',
             f"    return {code(rhs, {**ren, _EPS: 'eps', _K: 'K'})}",
             ""]
    if len(law.powers) == 1:
        (p,) = law.powers
        rate_k = _EPS * law.symbolic_coefficients[0] / _K
        lines.append(f"LAW_POWER = {const(float(p))}  # dB/di = k B^p")
        lines.append(f"def law_closed(i, A0, i0, {sig}):")
        lines.append(
            f'    """Closed-form A(i) ({law.kind}). Returns (A, base): base <= 0 means the law has ended '
            '(extinction for p < 1, blow-up for p > 1); A is then 0."""'
        )
        lines.append(f"    k = {code(rate_k, {**ren, _EPS: 'eps', _K: 'K'})}")
        if law.kind == "exponential":
            lines.append("    A = A0 * numpy.exp(k * (i - i0) / Q)")
            lines.append("    return A, numpy.ones_like(numpy.asarray(A, dtype=float))")
        else:
            lines.append(f"    base = A0 ** (Q * {const(float(1 - p))}) + {const(float(1 - p))} * k * (i - i0)")
            lines.append(f"    return numpy.where(base > 0, numpy.abs(base) ** ({const(float(1 / (ex.Q * (1 - p))))}), 0.0), base")
        lines.append("")
    return lines
