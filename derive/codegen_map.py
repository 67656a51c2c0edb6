"""The generated map module: residuals of Eq. 23 with their Jacobian, the long-wave right-hand
side and closed-form law (Eq. 30) and the stationary function of Eq. 41 with its derivatives.

Parameter arguments are named by :func:`pulsemap.symbolic.codeprint.param_identifier`; ``PARAMS``
lists the user's parameter names, ``ARGS`` the (name, bead offset) of each parameter argument in
order (("i", 0) is the bead index).
"""

from __future__ import annotations

import sympy

from .amplitude_map import A_I, A_NEXT, A_PREV, EPS, F_SYMBOLS, AmplitudeMap, integral_symbol
from .codeprint import code, const, measured, module, param_args, param_identifier, profile_peak, start, title
from .expansion import expand
from .expression import parse_expression, symbol
from .integrals import F_NAMES, constants
from .longwave import A0 as SYM_A0
from .longwave import I as SYM_I
from .longwave import I0 as SYM_I0
from .longwave import LAW_RATE
from .longwave import LongwaveError, longwave_law
from .sources import MapSource

#: Internal symbols of the generated formulas (plain sympy Symbols: never equal to a user's).
_B = sympy.Symbol("B", positive=True)
_EPS = sympy.Symbol("eps", real=True)
_K = LAW_RATE  # the law's rate, the local variable k in the generated code
_A = sympy.Symbol("A", positive=True)


def f_block(values: dict, profile: str) -> list[str]:
    """f1..f7 with the identities that hold exactly written as identities (not rounded twice)."""
    lines = [
        f"f1 = {const(values['f1'])}",
        f"f2 = {const(values['f2'])}",
        f"f3 = 2 * f2 - f1  # f1 - 2 f2 + f3 = S'(0) = 0 for an even profile; quadrature: {const(values['f3'])}",
        "f5 = f2  # Eq. 22: same integral as f2",
        "f6 = f3  # Eq. 22: same integral as f3",
        f"f7 = {const(values['f7'])}",
    ]
    if profile == "exact":
        lines.append(f"f4 = f5 - 2 * f6 + f7  # Eq. 4 integrated over (-inf, -1]; quadrature: {const(values['f4'])}")
    else:
        lines.append(f"f4 = {const(values['f4'])}  # S'(-1) of the Pade form (Eq. 4 does not hold for it)")
    return lines


def generate_map(source: MapSource) -> str:
    """The text of the map module for ``source`` (pure function of the source)."""
    R = parse_expression(source.R, source.params)
    n = sympy.Rational(source.n)
    ex = expand(R, n, source.site_dependent)
    names = list(F_NAMES) + list(ex.integrals())
    consts = constants(names, n=float(n), profile=source.profile, dps=source.dps)
    values = {k: measured(c.value, c.error) for k, c in consts.items()}
    amap = AmplitudeMap(n, source.variant, ex, values, {})
    args, described, param_names = param_args(source, ex.terms, (0, 1, 2))
    ren: dict[sympy.Symbol, str] = {A_PREV: "a_prev", A_I: "a_i", A_NEXT: "a_next", EPS: "eps"}
    ren.update(param_names)
    for k in F_SYMBOLS:
        ren[F_SYMBOLS[k]] = k
    for k in ex.integrals():
        ren[integral_symbol(k)] = k
    sig = ", ".join(["eps"] + args)
    eqs = amap.equations(numeric=False)
    lines = start(source)
    lines.append(f"VARIANT = {source.variant!r}")
    lines.append(f"PARAMS = {tuple(dict.fromkeys(name for name, _ in described if name != 'i'))!r}")
    lines.append(f"ARGS = {tuple(described)!r}  # (parameter, bead offset) of each argument after eps; ('i', 0): bead index")
    lines.append(f"P = {const(float((n + 1) / 2))}  # contact power (n + 1)/2")
    lines.append(f"N_EXPONENT = {const(float(n))}")
    lines.append("")
    lines.append(f"# universal constants ({source.profile} profile, mpmath dps {source.dps}), to the digits they are accurate to")
    lines.extend(f_block(values, source.profile))
    for k in names:
        if k not in F_NAMES:
            lines.append(f"{k} = {const(values[k])}")
    lines.append(f"S0 = {const(profile_peak(source.profile, float(n)))}  # peak = A S(0), Eq. 32")
    lines.append("")
    lines.extend(_residual_lines(source.variant, eqs, ren, sig))
    lines.extend(_power_table_lines(amap, source.variant, args, ren))
    uniform = not source.site_dependent and "i" not in args
    lines.append(f"UNIFORM = {uniform!r}")
    law = None
    if uniform:
        try:
            law = longwave_law(amap, 1.0, seconds=0)  # eps enters below explicitly
        except LongwaveError:
            law = None
    if law is not None and law.powers:
        lines.extend(_law_lines(law, amap, ren, sig, args, described))
    else:
        lines.append("LAW_KIND = None")
    what = f"Amplitude map (Eq. 23, {source.variant} variant), long-wave law (Eq. 30), Eq. 41"
    return module(lines, title(what, source, f", variant = {source.variant}"), source)


def _residual_lines(variant: str, eqs, ren: dict, sig: str) -> list[str]:
    """map_residual and map_jacobian (Eq. 23) as code lines."""
    unknowns = [A_I] if variant == "1d" else [A_I, A_NEXT]
    state = "a_prev, a_i" if variant == "1d" else "a_prev, a_i, a_next"
    lines = [f"def map_residual({state}, {sig}):",
             f'    """Residuals of Eq. 23 ({variant} variant). State: {state}; parameters: {sig}."""']
    for idx, e in enumerate(eqs, 1):
        lines.append(f"    F{idx} = {code(e, ren)}")
    lines.append(f"    return ({', '.join(f'F{k}' for k in range(1, len(eqs) + 1))},)")
    lines.append("")
    lines.append(f"def map_jacobian({state}, {sig}):")
    lines.append(
        f'    """d(F)/d(unknowns) as nested tuples, unknowns = ({", ".join(ren[u] for u in unknowns)}), '
        'and dF/da_prev (for multipliers)."""'
    )
    rows = []
    for idx, e in enumerate(eqs, 1):
        for jdx, unk in enumerate(unknowns, 1):
            lines.append(f"    J{idx}{jdx} = {code(sympy.diff(e, unk), ren)}")
        lines.append(f"    D{idx} = {code(sympy.diff(e, A_PREV), ren)}")
        rows.append("(" + ", ".join(f"J{idx}{j}" for j in range(1, len(unknowns) + 1)) + ",)")
    lines.append(f"    return ({', '.join(rows)},), ({', '.join(f'D{k}' for k in range(1, len(eqs) + 1))},)")
    lines.append("")
    return lines


def _power_table_lines(amap: AmplitudeMap, variant: str, args: list[str], ren: dict) -> list[str]:
    """Eq. 23 as data for the compiled map kernel (solvers/models/map_kernel.py): alpha, beta, the
    powers of the eps sums and their coefficients K_k (functions of the parameters; eps not included)."""
    alpha, beta = amap.alpha_beta(numeric=False)
    terms1 = amap.power_terms(1, numeric=False)
    terms2 = () if variant == "1d" else amap.power_terms(2, numeric=False)
    return [
        "# Eq. 23 as a power-term table: F1 = f1 a_prev^P - 2 f2 a_i^P + f3 a_next^P + eps sum_k K1_k a_i^p_k,",
        "# F2 = ALPHA a_i^P - BETA a_next^P + eps sum_k K2_k a_next^q_k (1d: a_next -> a_i in F1, no F2)",
        f"ALPHA = {code(alpha, ren)}",
        f"BETA = {code(beta, ren)}",
        f"MAP_POWERS1 = ({''.join(const(float(t.power)) + ', ' for t in terms1)})",
        f"MAP_POWERS2 = ({''.join(const(float(t.power)) + ', ' for t in terms2)})",
        "",
        f"def map_power_coefficients({', '.join(args)}):",
        '    """(K1, K2): the coefficients of the eps sums of Eq. 23, one per power (arguments as in map_residual after eps)."""',
        f"    K1 = ({''.join(code(t.coefficient, ren) + ', ' for t in terms1)})",
        f"    K2 = ({''.join(code(t.coefficient, ren) + ', ' for t in terms2)})",
        "    return K1, K2",
        "",
    ]


def _law_lines(law, amap: AmplitudeMap, ren: dict, sig: str, args: list[str], described) -> list[str]:
    """longwave_rhs, longwave_law (one power) and stationary, stationary_dparam (Eq. 41) as code lines."""
    f13 = F_SYMBOLS["f1"] - F_SYMBOLS["f3"]
    rhs = _EPS / f13 * sum((c * _B**p for c, p in zip(law.symbolic_coefficients, law.powers)), sympy.Integer(0))
    lines = [f"LAW_KIND = {law.kind!r}",
             f"def longwave_rhs(B, {sig}):",
             f'    """dB/di of Eq. 30, B = A^P. Parameters: {sig}."""',
             f"    return {code(rhs, {**ren, _B: 'B', _EPS: 'eps'})}",
             ""]
    if law.law is not None:
        rate = _EPS * law.symbolic_coefficients[0] / f13
        plain = {SYM_A0: "A0", SYM_I: "i", SYM_I0: "i0", _K: "k"}
        lines.append(f"def longwave_law(i, A0, i0, {sig}):")
        lines.append(
            f'    """Closed-form A(i) of Eq. 30 ({law.kind}); nan-free: caller checks the base. '
            'Returns (A, base) where base <= 0 means the law has ended (extinction/blow-up)."""'
        )
        lines.append(f"    k = {code(rate, {**ren, _EPS: 'eps'})}")
        if law.kind == "exponential":
            lines.append(f"    A = {code(law.law, plain)}")
            lines.append("    return A, numpy.ones_like(numpy.asarray(A, dtype=float))")
        else:
            (p,) = law.powers
            base = SYM_A0 ** (law.P * (1 - p)) + (1 - p) * _K * (SYM_I - SYM_I0)
            lines.append(f"    base = {code(base, plain)}")
            lines.append("    safe = numpy.where(base > 0, base, 1.0)")
            lines.append(f"    return safe ** ({const(float(1 / (law.P * (1 - p))))}), base")
        lines.append("")
    phi = sum((t.coefficient * _A**t.power for t in amap.power_terms(1, numeric=False)), sympy.Integer(0))
    pargs = ", ".join(args)
    with_a = {**ren, _A: "A"}
    lines.append(f"def stationary(A{', ' + pargs if pargs else ''}):")
    lines.append('    """Phi(A) of Eq. 41 (eps divided out) and dPhi/dA."""')
    lines.append(f"    return {code(phi, with_a)}, {code(sympy.diff(phi, _A), with_a)}")
    lines.append("")
    lines.append(f"def stationary_dparam(A{', ' + pargs if pargs else ''}):")
    lines.append('    """dPhi/d(parameter) for each parameter (by the user\'s name), as a dict (for continuation)."""')
    items = ", ".join(f"{name!r}: {code(sympy.diff(phi, symbol(name)), with_a)}" for name, _ in described)
    lines.append(f"    return {{{items}}}")
    lines.append("")
    assert all(a == param_identifier(name) for a, (name, _) in zip(args, described))
    return lines
