"""``pulsemap.derive``: from a perturbation R(u, v) to the amplitude map (paper Eq. 23), the long-wave
law (Eq. 30 and its solution A(i)) and the stationary-shock equation (Eq. 41) with its roots."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

from pulsemap.solvers.api.checks import api_hint, choice, merged_params, number

__all__ = ["Derivation", "derive"]

PROFILES = ("exact", "pade")
VARIANTS = ("paper", "corrected", "1d")


@dataclass(frozen=True)
class Derivation:
    """Everything derived for one perturbation eps R(u, v), with the choices that produced it.

    Equations are text in sympy's notation (``str``); :attr:`latex` has them in LaTeX. Integrals
    of the solitary-wave profile appear as symbols (``f1`` ... ``f7``, ``g1_klmq``, ``g2_pr``) whose values are in
    :attr:`constants`. Build one with :func:`pulsemap.derive`.
    """

    R: str
    """The perturbation as given."""
    eps: float
    """The small parameter in front of R."""
    params: Mapping[str, Any]
    """Parameter values of R."""
    n: float
    """Hertz exponent of the chain (1.5 for spheres)."""
    profile: str
    """Solitary-wave profile of the integrals: "exact" or "pade"."""
    variant: str
    """Map variant: "paper" (Eq. 23 as printed), "corrected" or "1d"."""
    S0: float
    """Peak S(0) of the unit solitary wave: a peak is A S(0)."""
    constants: Mapping[str, float]
    """Values of the profile integrals that occur."""
    map: tuple[str, ...]
    """The amplitude map, Eq. 23, one ``0 = ...`` per equation."""
    map_numeric: tuple[str, ...]
    """The same with the constants substituted."""
    ode: str | None
    """The long-wave ODE, Eq. 30, in B = A^P (for a site-dependent R with coefficients C_p(i));
    None when there is no law."""
    law: str | None
    """The long-wave law: ``A(i) = ...`` (closed form), ``i(A) = ...`` (implicit),
    ``A(i) = A_0`` (no forcing), or None (by quadrature only, or no law: see :attr:`notes`)."""
    law_kind: str | None
    """"power law", "exponential", "implicit", "quadrature" or "constant"."""
    rate: float | None
    """lambda_L = eps C / (f1 - f3) of a uniform single-power law (the lambda_L in :attr:`law`)."""
    stationary: str | None
    """Eq. 41, ``0 = Phi(A)``; None for a site-dependent R."""
    roots: tuple[float, ...]
    """Positive roots A of Eq. 41 (stationary shocks)."""
    notes: Mapping[str, str]
    """Why the law or Eq. 41 is not available, when it is not."""
    details: Any = field(default=None, repr=False, compare=False)
    """The internal derivation object (pulsemap.symbolic.derivation.Derivation); not a stable interface."""

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


def derive(
    R: str,
    *,
    eps: float = 0.1,
    n: float = 1.5,
    profile: str = "exact",
    variant: str = "paper",
    params: Mapping[str, Any] | None = None,
    **parameters: Any,
) -> Derivation:
    """Derive the map (Eq. 23), the long-wave law (Eq. 30) and Eq. 41 for eps R(u, v).

    ``R`` is a formula in the strain u, its rate v, the bead index i and parameters, e.g.
    ``"-mu*v"`` (damping) or ``"-(u - mu*(1 - u^2)*v)"`` (Van der Pol); give each parameter as a
    keyword (``mu=1``) or in ``params`` (for a name that clashes with an argument, e.g. ``n``).
    Parameter values are numbers, lists of per-bead values or expressions of i (text).

    >>> d = derive("-mu*v", mu=1)
    >>> print(d.law)  # doctest: +SKIP
    A(i) = (A_0**(1/4) + lambda_L*(i - i_0)/5)**4

    Raises TypeError or ValueError naming the argument for bad input.
    """
    from pulsemap.symbolic.amplitude_map import MapError
    from pulsemap.symbolic.derivation import DerivationError, derive_all
    from pulsemap.symbolic.expression import ExpressionError
    from pulsemap.symbolic.perturbation import PerturbationError, check_all_used, make_perturbation
    from pulsemap.symbolic.profile import ProfileError
    from pulsemap.symbolic.stationary import StationaryError

    if not isinstance(R, str):
        raise TypeError(f"R must be a string formula in u, v, i and parameters (e.g. '-mu*v'), got {type(R).__name__}")
    eps = number(eps, "eps")
    n = number(n, "n")
    profile = choice(profile, "profile", PROFILES)
    variant = choice(variant, "variant", VARIANTS)
    values = merged_params(params, parameters)
    try:
        pert = check_all_used(make_perturbation(R, eps, values))
        d = derive_all(pert, n=n, profile=profile, variant=variant)
    except (PerturbationError, ExpressionError, ProfileError, MapError, DerivationError, StationaryError) as exc:
        raise ValueError(api_hint(str(exc))) from None
    return _public(R, d)


def _public(R: str, d: Any) -> Derivation:
    from pulsemap.symbolic.longwave import LongwaveLaw

    law = d.longwave  # a LongwaveLaw, or a SiteLaw (derive/site_law.py) for a site-dependent R
    uniform = isinstance(law, LongwaveLaw)
    if law is None:
        law_text = None
    elif law.kind == "constant":
        law_text = "A(i) = A_0"
    elif law.law is not None:
        law_text = f"A(i) = {law.law}"
    elif uniform and law.implicit is not None:
        law_text = f"i(A) = {law.implicit}"
    else:
        law_text = None
    ode = None if law is None else f"{law.ode().lhs} = {law.ode().rhs}"
    st = d.stationary
    notes = {key: text for key, text in (("law", d.longwave_note), ("stationary", d.stationary_note)) if text}
    from pulsemap.symbolic.perturbation import param_data

    return Derivation(
        R=R,
        eps=float(d.perturbation.eps),
        params={k: param_data(v) for k, v in d.perturbation.params.items()},
        n=float(d.n),
        profile=d.profile,
        variant=d.variant,
        S0=float(d.S0),
        constants=dict(d.constants),
        map=tuple(f"0 = {e}" for e in d.amap.equations()),
        map_numeric=tuple(f"0 = {e}" for e in d.amap.equations(numeric=True)),
        ode=ode,
        law=law_text,
        law_kind=None if law is None else law.kind,
        rate=(law.rate() if uniform and len(law.powers) == 1 else None),
        stationary=None if st is None else f"0 = {st.equation}",
        roots=() if st is None else tuple(float(r) for r in st.roots),
        notes=notes,
        details=d,
    )
