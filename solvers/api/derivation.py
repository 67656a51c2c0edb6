"""``pulsemap.derive``: from a perturbation R(u, v) to the amplitude map (paper Eq. 23), the long-wave
law (Eq. 30 and its solution A(i)) and the stationary-shock equation (Eq. 41) with its roots."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Mapping

if TYPE_CHECKING:  # pragma: no cover - sympy loads when a derivation is made, not on import
    import sympy

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.api.checks import api_hint, choice, merged_params, number

__all__ = ["Balance", "Derivation", "derive"]

PROFILES = ("exact", "pade")
VARIANTS = ("paper", "corrected", "1d")


@dataclass(frozen=True)
class Derivation:
    """Everything derived for one perturbation eps R(u, v), with the choices that produced it.

    The equations are sympy objects (``sympy.Eq``) in plain symbols (``sympy.Symbol(name)``, no
    assumptions; the user's own symbol objects when R was given as sympy): u, v, i and the parameters of
    R; a parameter given no value stays a symbol (:attr:`free`). Integrals of the solitary-wave profile
    appear as symbols (``f1`` ... ``f7``, ``g1_klmq``, ``g2_pr``) and eps as ``epsilon``; :attr:`symbols`
    maps every name to its symbol, and :attr:`values` maps the symbols with a number to it, so
    ``d.law.subs(d.values)`` is the numeric law and ``d.law.subs({"mu": 2})``, ``d.law.subs(mu, 2)`` (with
    ``mu = sympy.Symbol("mu")``), ``sympy.lambdify`` and ``sympy.solve`` work as in any sympy code. ``str(d)``
    is the report of ``pulsemap derive``, :attr:`latex` its LaTeX (shown by Jupyter), ``to_dict()`` its
    JSON. Build one with :func:`pulsemap.derive`.
    """

    R: sympy.Expr
    """The perturbation R(u, v) as a sympy expression (symbols u, v, i and parameters)."""
    expression: str
    """R as given (text), or sympy's text of a sympy R."""
    eps: float
    """The small parameter in front of R."""
    params: Mapping[str, Any]
    """Parameter values of R (numbers, per-bead lists, expressions of i)."""
    free: tuple[str, ...]
    """Parameters of R given no value: symbols in every equation (a number is asked for where one is needed)."""
    n: float
    """Hertz exponent of the chain (1.5 for spheres)."""
    profile: str
    """Solitary-wave profile of the integrals: "exact" or "pade"."""
    variant: str
    """Map variant: "paper" (Eq. 23 as printed), "corrected" or "1d"."""
    S0: float
    """Peak S(0) of the unit solitary wave: a peak is A S(0)."""
    constants: Mapping[str, float]
    """Values of the profile integrals that occur, by name."""
    map: tuple[sympy.Eq, ...]
    """The amplitude map, Eq. 23: ``Eq(0, F_k)`` for each equation, in A_{i-1}, A_i, A_{i+1}."""
    ode: sympy.Eq | None
    """The long-wave ODE, Eq. 30, ``Eq((f1 - f3) B'(i), epsilon sum C_p B(i)^p)`` with B = A^P (coefficients
    C_p(i) for a site-dependent R); None when there is no law."""
    law: sympy.Eq | None
    """The long-wave law: ``Eq(A(i), ...)`` (closed form in A_0, i, i_0, epsilon, the integrals and the
    parameters), ``Eq(i, ...)`` (implicit i(A), numeric constants), or None (by quadrature only, or no law:
    see :attr:`notes`)."""
    law_kind: str | None
    """"power law", "exponential", "implicit", "quadrature" or "constant"."""
    stationary: sympy.Eq | None
    """Eq. 41, ``Eq(0, Phi(A))``; None for a site-dependent R."""
    notes: Mapping[str, str]
    """Why the law or Eq. 41 is not available, when it is not."""
    symbols: Mapping[str, sympy.Symbol] = field(default_factory=dict, repr=False)
    """Every symbol of R and of the equations, by name (``d.symbols["mu"]``, ``d.symbols["A_0"]``)."""
    details: Any = field(default=None, repr=False, compare=False)
    """The internal derivation object (pulsemap.symbolic.derivation.Derivation); not a stable interface."""

    @property
    def values(self) -> dict[sympy.Symbol, float]:
        """Numbers of the symbols in the equations: the profile integrals, epsilon and the scalar
        parameters given a value (``expr.subs(d.values)``)."""
        from pulsemap.symbolic.amplitude_map import integral_symbol

        values = {**{integral_symbol(k): v for k, v in self.constants.items()}, **_scalar_values(self)}
        return {_public_symbol(s, self.symbols, self.details.perturbation): v for s, v in values.items()}

    @property
    def rate(self) -> float | None:
        """lambda_L = eps C / (f1 - f3) of a uniform single-power law; None for other laws. ValueError
        naming the parameter when it needs a value that was not given."""
        from pulsemap.symbolic.longwave import LongwaveLaw

        law = self.details.longwave
        if not isinstance(law, LongwaveLaw) or len(law.powers) != 1:
            return None
        return law.rate()

    @property
    def roots(self) -> tuple[float, ...]:
        """Positive roots A of Eq. 41 (stationary shocks); () without Eq. 41. ValueError naming the
        parameters when Eq. 41 depends on one given no value."""
        from pulsemap.symbolic.longwave import needs_values

        st = self.details.stationary
        if st is None:
            return ()
        if st.missing:
            raise PulsemapError(needs_values("the roots of Eq. 41", st.missing))
        return tuple(float(r) for r in st.roots)

    @property
    def stationary_peaks(self) -> tuple[float, ...]:
        """Peaks A S(0) of the stationary shocks."""
        return tuple(a * self.S0 for a in self.roots)

    @property
    def latex(self) -> str:
        """The map, the long-wave ODE and law, and Eq. 41 in LaTeX, one equation a line."""
        from pulsemap.symbolic.derivation import to_latex

        return "\n".join(line for line in to_latex(self.details).splitlines() if not line.startswith("%"))

    def _repr_latex_(self) -> str:
        lines = self.latex.splitlines()
        return "$$\\begin{align}" + " \\\\\n".join(lines) + "\\end{align}$$"

    def to_dict(self) -> dict:
        """JSON-serialisable data: the same document as ``pulsemap derive --json`` (with provenance)."""
        from pulsemap.symbolic.derivation import to_json

        return to_json(self.details)

    def __str__(self) -> str:
        from pulsemap.symbolic.derivation import to_text

        return to_text(self.details)

    def __repr__(self) -> str:
        models = ["map (Eq. 23)", f"law ({self.law_kind or 'none'})"]
        models += ["Eq. 41"] if self.stationary is not None else []
        free = f", free={list(self.free)}" if self.free else ""
        return f"Derivation(R={self.expression!r}, eps={self.eps:g}, n={self.n:g}{free}: {', '.join(models)})"

    def balance(self, model: str = "energy") -> "Balance":
        """The energy- or momentum-balance model of the same R (beyond the paper; ``pulsemap derive
        --model energy``): its map and law as sympy equations. ValueError when the model is undefined
        for R (a momentum balance of a foundation term, whose impulse diverges)."""
        import sympy

        from pulsemap.symbolic.balance import K_SYMBOLS, BalanceError, derive_balance, map_equation

        model = choice(model, "model", ("energy", "momentum"))
        try:
            b = derive_balance(self.details.perturbation, model, n=self.n, profile=self.profile)
        except BalanceError as exc:
            raise PulsemapError(api_hint(str(exc))) from None
        law, pert = b.law, self.details.perturbation
        equations = {"map": map_equation(b), "ode": None if law is None else law.ode(),
                     "law": _law_equation(law, K_SYMBOLS[model])}
        values = {**{sympy.Symbol(k, real=True): v for k, v in b.constants.items()}, K_SYMBOLS[model]: b.K,
                  **_scalar_values(self)}
        table = _symbol_table([pert.R, *equations.values(), *values], self.symbols, pert)
        return Balance(
            model=model,
            **{key: None if eq is None else eq.xreplace(table) for key, eq in equations.items()},
            law_kind=None if law is None else law.kind,
            constants={**b.constants, K_SYMBOLS[model].name: b.K},
            values={table[s]: v for s, v in values.items()},
            notes={"law": b.law_note} if b.law_note else {},
            symbols=_by_name(table),
            details=b,
        )


@dataclass(frozen=True)
class Balance:
    """The energy- or momentum-balance model of a perturbation as sympy equations (from
    :meth:`Derivation.balance`): the wave's energy E_1 A^(n+1) (or momentum p_1 A^(1+s)) changes at
    each bead by the work (impulse) of eps R on it."""

    model: str
    """"energy" or "momentum"."""
    map: sympy.Eq
    """The balance map, ``Eq(K A_i^Q, K A_{i-1}^Q + epsilon W(A_{i-1}))`` (K = E_1 or p_1)."""
    ode: sympy.Eq | None
    """The balance law's ODE, ``Eq(K B'(i), epsilon sum C_p B(i)^p)``, B = A^Q; None without a law."""
    law: sympy.Eq | None
    """``Eq(A(i), ...)`` in closed form, ``Eq(i, ...)`` implicit, or None (by quadrature only)."""
    law_kind: str | None
    """"power law", "exponential", "implicit", "quadrature" or "constant"."""
    constants: Mapping[str, float]
    """Values of the wave's integrals (w_ab or j_ab, K1, V1, D, ...) and of K, by name."""
    values: Mapping[sympy.Symbol, float]
    """Numbers of the symbols in the equations (integrals, K, epsilon, parameters given a value)."""
    notes: Mapping[str, str]
    """Why the law is not available, when it is not."""
    symbols: Mapping[str, sympy.Symbol] = field(default_factory=dict, repr=False)
    """Every symbol of the equations, by name (plain symbols, as in :attr:`Derivation.symbols`)."""
    details: Any = field(default=None, repr=False, compare=False)
    """The internal balance derivation (pulsemap.symbolic.balance.BalanceDerivation); not a stable interface."""

    @property
    def latex(self) -> str:
        """The balance map, ODE and law in LaTeX, one equation a line."""
        from pulsemap.symbolic.balance import to_latex

        return "\n".join(line for line in to_latex(self.details).splitlines() if not line.startswith("%"))

    def _repr_latex_(self) -> str:
        return "$$\\begin{align}" + " \\\\\n".join(self.latex.splitlines()) + "\\end{align}$$"

    def to_dict(self) -> dict:
        """JSON-serialisable data: the document of ``pulsemap derive --model energy|momentum --json``."""
        from pulsemap.symbolic.balance import to_json

        return to_json(self.details)

    def __str__(self) -> str:
        from pulsemap.symbolic.balance import to_text

        return to_text(self.details)

    def __repr__(self) -> str:
        pert = self.details.perturbation
        return (f"Balance(model={self.model!r}, R={pert.text!r}, eps={pert.eps:g}: map, "
                f"law ({self.law_kind or 'none'}))")


def _public_symbol(s: Any, given: Mapping[str, Any], pert: Any) -> Any:
    """The public symbol of an internal one: the user's own object (``given``) or a plain Symbol(name).

    The derivation makes its symbols with assumptions (real, positive) that its algebra needs; a user's
    ``Symbol("mu")`` or ``subs({"mu": 2})`` would never match them. A symbol of the derivation (f1,
    epsilon, A_0, ...) whose name is also a parameter of R keeps its own object, so the two stay apart."""
    import sympy

    from pulsemap.symbolic.expression import UserSymbol

    if not isinstance(s, sympy.Symbol) or isinstance(s, (sympy.Dummy, sympy.Wild)):
        return s
    if not isinstance(s, UserSymbol) and (s.name in pert.params or s.name in pert.used_parameters):
        return s
    return given.get(s.name) or sympy.Symbol(s.name)


def _symbol_table(exprs: Any, given: Mapping[str, Any], pert: Any) -> dict:
    """{internal symbol: public symbol} for every symbol in ``exprs`` (:func:`_public_symbol`)."""
    import sympy

    atoms = set().union(*(e.atoms(sympy.Symbol) for e in exprs if e is not None))
    return {s: _public_symbol(s, given, pert) for s in atoms}


def _by_name(table: Mapping[Any, Any]) -> dict:
    """{name: public symbol}; where a parameter and a symbol of the derivation share a name, the parameter's."""
    kept = {s.name: s for internal, s in table.items() if s is internal}
    return dict(sorted({**kept, **{s.name: s for internal, s in table.items() if s is not internal}}.items()))


def _scalar_values(d: Derivation) -> dict:
    """epsilon and the scalar parameters given a value, as {symbol: number}."""
    from pulsemap.symbolic.amplitude_map import EPS

    out = {EPS: d.eps}
    out.update({k: float(v) for k, v in d.details.perturbation.scalar_values().items()})
    return out


def _law_equation(law: Any, scale: Any) -> Any:
    """A law as a sympy Eq: A(i) = closed form with lambda_L = epsilon C / scale written out (scale: f1 - f3
    or E_1, p_1), i = i(A) for an implicit law, None when only a quadrature solves it."""
    import sympy

    from pulsemap.symbolic.amplitude_map import EPS
    from pulsemap.symbolic.longwave import I, LAW_RATE

    if law is None:
        return None
    if law.law is not None:
        expr = law.law
        if getattr(law, "symbolic_coefficients", ()) and law.powers:  # uniform: the rate in the user's symbols
            expr = expr.xreplace({LAW_RATE: EPS * law.symbolic_coefficients[0] / scale})
        return sympy.Eq(sympy.Function("A")(I), expr, evaluate=False)
    if getattr(law, "implicit", None) is not None:
        return sympy.Eq(I, law.implicit, evaluate=False)  # i(A), A the amplitude symbol
    return None


def derive(
    R: str | sympy.Expr,
    *,
    eps: float = 0.1,
    n: float = 1.5,
    profile: str = "exact",
    variant: str = "paper",
    params: Mapping[str, Any] | None = None,
    **parameters: Any,
) -> Derivation:
    """Derive the map (Eq. 23), the long-wave law (Eq. 30) and Eq. 41 for eps R(u, v), as sympy equations.

    ``R`` is a formula in bead i's displacement u = x_i, its velocity v = x_i', the bead index i and
    parameters, as text (``"-mu*v"`` for damping, ``"-(u - mu*(1 - u^2)*v)"`` for Van der Pol) or as a
    sympy expression in symbols of those names. Give a parameter's value as a keyword (``mu=1``) or in ``params`` (for a
    name that clashes with an argument, e.g. ``n``): a number, a list of per-bead values or an
    expression of i (text). A parameter given no value stays a sympy symbol; what needs a number
    (the roots of Eq. 41, the rate lambda_L) then raises ValueError naming it.

    >>> d = derive("-mu*v")
    >>> d.law  # doctest: +SKIP
    Eq(A(i), (A_0**(1/4) - epsilon*g1_0010*mu*(i - i_0)/(5*(f1 - f3)))**4)

    Raises TypeError or ValueError naming the argument for bad input.
    """
    from sympy import Symbol

    from pulsemap.symbolic.amplitude_map import MapError
    from pulsemap.symbolic.derivation import DerivationError, derive_all
    from pulsemap.symbolic.expression import ExpressionError
    from pulsemap.symbolic.perturbation import PerturbationError, check_all_used, make_perturbation
    from pulsemap.symbolic.profile import ProfileError
    from pulsemap.symbolic.stationary import StationaryError

    _check_R(R)
    eps = number(eps, "eps")
    n = number(n, "n")
    profile = choice(profile, "profile", PROFILES)
    variant = choice(variant, "variant", VARIANTS)
    values = merged_params(params, parameters)
    try:
        pert = check_all_used(make_perturbation(R, eps, values, free=True))
        d = derive_all(pert, n=n, profile=profile, variant=variant)
    except (PerturbationError, ExpressionError, ProfileError, MapError, DerivationError, StationaryError) as exc:
        raise PulsemapError(api_hint(str(exc))) from None
    return _public(d, {} if isinstance(R, str) else {s.name: s for s in R.atoms(Symbol)})


def _check_R(R: Any) -> None:
    """R must be text or a sympy expression (TypeError otherwise)."""
    if isinstance(R, str):
        return
    import sympy

    if not isinstance(R, sympy.Expr):
        raise TypeError("R must be a string formula or a sympy expression in u, v, i and parameters "
                        f"(e.g. '-mu*v'), got {type(R).__name__}")


def _public(d: Any, given: Mapping[str, Any]) -> Derivation:
    """The public Derivation of an internal one, its equations in the public symbols (:func:`_public_symbol`;
    ``given``: the user's own symbols of a sympy R, by name)."""
    import sympy

    from pulsemap.symbolic.amplitude_map import EPS, F_SYMBOLS, integral_symbol
    from pulsemap.symbolic.perturbation import param_data

    law = d.longwave  # a LongwaveLaw, or a SiteLaw (derive/site_law.py) for a site-dependent R
    st = d.stationary
    notes = {key: text for key, text in (("law", d.longwave_note), ("stationary", d.stationary_note)) if text}
    pert = d.perturbation
    equations = {
        "map": tuple(sympy.Eq(0, e, evaluate=False) for e in d.amap.equations()),
        "ode": None if law is None else law.ode(),
        "law": _law_equation(law, F_SYMBOLS["f1"] - F_SYMBOLS["f3"]),
        "stationary": None if st is None else sympy.Eq(0, st.equation, evaluate=False),
    }
    valued = [EPS, *(integral_symbol(k) for k in d.constants), *pert.scalar_values()]
    table = _symbol_table([pert.R, *equations["map"], equations["ode"], equations["law"], equations["stationary"],
                           *valued], given, pert)
    public = {key: None if eq is None else eq.xreplace(table) for key, eq in equations.items() if key != "map"}
    return Derivation(
        R=pert.R.xreplace(table),
        expression=pert.text,
        eps=float(pert.eps),
        params={k: param_data(v) for k, v in pert.params.items()},
        free=pert.free_parameters,
        n=float(d.n),
        profile=d.profile,
        variant=d.variant,
        S0=float(d.S0),
        constants=dict(d.constants),
        map=tuple(eq.xreplace(table) for eq in equations["map"]),
        ode=public["ode"],
        law=public["law"],
        law_kind=None if law is None else law.kind,
        stationary=public["stationary"],
        notes=notes,
        symbols=_by_name(table),
        details=d,
    )


def quadrature_energy_law(pert: Any, n: float = 1.5) -> dict:
    """The energy law of a uniform R that is not a polynomial in u, v, as JSON data: E_1 dB/di = W(A),
    B = A^(n+1), with W(A) tabulated by quadrature over the wave exactly as ``run --methods energy-law``
    evaluates it (solvers/models/energy_quadrature.py), each value with its quadrature error."""
    from pulsemap.symbolic.balance import json_header, model_title
    from pulsemap.symbolic.profile import check_exponent
    from pulsemap.solvers.models.codeload import force_module
    from pulsemap.solvers.models.energy_quadrature import RATE_TOLERANCE, EnergyQuadratureError, bead_force, off_poles, rate_table

    if not pert.is_uniform:
        raise PulsemapError(f"R = {pert.text} varies along the chain: the tabulated energy law needs a uniform R; "
                         "pulsemap run --methods energy-law evaluates it bead by bead")
    if pert.free_parameters:  # W(A) is a table of numbers
        names = pert.free_parameters
        raise PulsemapError(f"the energy law of R = {pert.text} by quadrature needs a value for {', '.join(names)}: give "
                         + " ".join(f"--param {name}=VALUE" for name in names))
    n = float(check_exponent(n))
    values = {name: float(value) for name, value in pert.params.items()}
    module = force_module(pert.text, pert.used_parameters)
    def params_at(bead: float) -> tuple:
        return tuple(values[name] for name in module.PARAMS)

    force = off_poles(bead_force(module, float(pert.eps), params_at), pert, module.PARAMS, params_at)
    t = rate_table(lambda x, v: force(x, v, 1.0), n)
    if all(r is None for r in t.rate):
        raise EnergyQuadratureError(
            f"R = {pert.text}: no tabulated rate of the energy law is resolved by the quadrature (its change with "
            f"{2 * t.nodes} instead of {t.nodes} nodes per unit interval exceeds {RATE_TOLERANCE:g} of its size at "
            "every amplitude): R varies too fast along the wave's path; smooth it or use pulsemap run --methods dns")
    rows = [{"A": a, "peak": a * t.S0, "rate_dB_di": r, "dlnA_di": g, "error": e, "resolved": r is not None}
            for a, r, g, e in zip(t.A, t.rate, t.dlnA_di(), t.error)]
    return {
        **json_header("energy", pert),
        "title": model_title("energy"),
        "method": "quadrature of R over the wave (R is not a polynomial in u, v)",
        "n": n,
        "profile": "exact",
        "S0": t.S0,
        "window_L": t.L,
        "nodes_per_unit": t.nodes,
        "wave": {"E1": t.E1, "K1": t.K1, "V1": t.V1, "kinetic_fraction": t.K1 / t.E1},
        "Q": f"{n + 1:g}",
        "law": {
            "kind": "quadrature (tabulated)",
            "ode": "Eq(E_1*Derivative(B(i), i), W(A))",
            "ode_numeric": f"Eq({t.E1!r}*Derivative(B(i), i), W(A))",
            "B": f"A**({n + 1:g})",
            "W": "eps*int R(A X, A^(1+s) X') A X' dtau over |tau| <= L (Gauss-Legendre)",
            "error": f"change of W/E_1 with {2 * t.nodes} instead of {t.nodes} nodes per unit interval",
            "table": rows,
            "tolerance": RATE_TOLERANCE,
            "tolerance_of": "A int |eps R X'| dtau / E_1 (the rate's size without cancellation): a rate whose error "
                            "is larger is not resolved (null)",
            "max_error": max(e for r, e in zip(t.rate, t.error) if r is not None),
            "max_rel_error": max((e / abs(r) for r, e in zip(t.rate, t.error) if r), default=0.0),
        },
    }


def quadrature_energy_text(doc: dict) -> str:
    """The report of :func:`quadrature_energy_law` (``pulsemap derive --model energy`` for such an R)."""
    law, wave = doc["law"], doc["wave"]
    lines = [
        f"Model: {doc['title']}",
        f"R(u, v) = {doc['R']}    eps = {doc['eps']:g}    n = {doc['n']:g}    profile = exact",
        f"R is not a polynomial in u, v: W(A) = {law['W']} (L = {doc['window_L']}, {doc['nodes_per_unit']} nodes "
        "per unit interval), as pulsemap run computes energy-map and energy-law",
        f"E_1 = K_1 + V_1 = {wave['K1']:.12g} + {wave['V1']:.12g} = {wave['E1']:.12g}",
        "",
        f"Law, B = {law['B']}:",
        f"  {law['ode']}",
        f"  {law['ode_numeric']}",
        f"Amplitude law: by quadrature, rate tabulated (error: {law['error']}):",
        f"  {'A':>12s} {'peak A S(0)':>14s} {'dB/di = W/E_1':>16s} {'d ln A/di':>14s} {'error':>10s}",
    ]
    for row in law["table"]:
        rate, g = ((f"{row['rate_dB_di']:16.9g}", f"{row['dlnA_di']:14.7g}") if row["resolved"]
                   else (f"{'not resolved':>16s}", f"{'-':>14s}"))
        lines.append(f"  {row['A']:12.6g} {row['peak']:14.6g} {rate} {g} {row['error']:10.2g}")
    lines.append(f"  largest relative error of the rate: {law['max_rel_error']:.2g}")
    if not all(row["resolved"] for row in law["table"]):
        lines.append(f"  not resolved: the error is above {law['tolerance']:g} of {law['tolerance_of'].split(':')[0]}")
    return "\n".join(lines)
