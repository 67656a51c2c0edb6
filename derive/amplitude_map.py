"""The two-dimensional amplitude map of Eq. 23 and its variants, as sympy and as data.

With P = (n + 1)/2 and A_{i-1} known, contact i gives (Eqs. 19, 22, 23)

    F1 = f1 A_{i-1}^P - 2 f2 A_i^P + f3 A_{i+1}^P + eps sum_j c_j g^(1)_j A_i^{e_j}      = 0
    F2 = alpha A_i^P - beta A_{i+1}^P            + eps sum_j d_j g^(2)_j A_{i+1}^{e_j}  = 0

Variants (erratum 5, docs/errata.rst and the remark after Eq. 23):

* ``paper``     alpha = f5 - f4, beta = 2 f6 (Eq. 23 as printed; drifts slowly even at eps = 0)
* ``corrected`` alpha = f5, beta = f4 + 2 f6 - f7 (inertia of contact i+1 taken at A_{i+1}, and
                the delta_{i+2} contact term kept; for the exact profile alpha = beta)
* ``1d``        A_{i+1} -> A_i in F1, which alone then fixes A_i; F2 is not used.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import sympy

from .errors import PulsemapError
from .expansion import Expansion, Term
from .sources import VARIANTS

A_PREV, A_I, A_NEXT = sympy.symbols("A_{i-1} A_i A_{i+1}", positive=True)
EPS = sympy.Symbol("epsilon", positive=True)
F_SYMBOLS = {name: sympy.Symbol(name, real=True) for name in ("f1", "f2", "f3", "f4", "f5", "f6", "f7")}


class MapError(PulsemapError):
    """A map that cannot be built as asked (unknown variant, ...)."""


def check_variant(variant: str) -> str:
    if variant not in VARIANTS:
        raise MapError(f"unknown map variant {variant!r}: choose one of {', '.join(VARIANTS)}")
    return variant


def integral_symbol(name: str) -> sympy.Symbol:
    """The symbol standing for integral ``name`` (g1_klmq, g2_pr) in printed equations."""
    return sympy.Symbol(name, real=True)


def latex_names(names) -> dict:
    """LaTeX names for the integral and constant symbols (g^{(1)}_{klmq}, f_1, ...)."""
    out = {}
    for name in names:
        if name.startswith("g1_"):
            out[integral_symbol(name)] = r"g^{(1)}_{" + name[3:].replace("_", ",") + "}"
        elif name.startswith("g2_"):
            out[integral_symbol(name)] = r"g^{(2)}_{" + name[3:].replace("_", ",") + "}"
    for name, sym in F_SYMBOLS.items():
        out[sym] = f"f_{name[1:]}"
    return out


@dataclass(frozen=True)
class PowerTerm:
    """sum of the terms of one equation with one power of A: K * A^power (K numeric when known)."""

    power: sympy.Rational
    coefficient: sympy.Expr  # symbolic: sum c_j * g_j (integrals as symbols)
    value: float | None  # numeric value of the coefficient (None when site-dependent)


@dataclass(frozen=True)
class AmplitudeMap:
    """Eq. 23 for a given expansion, variant and set of constants."""

    n: sympy.Rational
    variant: str
    expansion: Expansion
    constants: Mapping[str, float]  # f1..f7 and the integrals that occur
    params: Mapping[sympy.Symbol, sympy.Expr]  # scalar parameter values (uniform part)
    _memo: dict = field(default_factory=dict, compare=False, repr=False)  # power_terms by (equation, numeric)

    @property
    def P(self) -> sympy.Rational:
        """Power of the contact terms, (n + 1)/2 (5/4 for Hertz)."""
        return (self.n + 1) / 2

    def alpha_beta(self, numeric: bool = True):
        """(alpha, beta) of F2 for this variant (symbolic in f's unless ``numeric``)."""
        f = {k: (self.constants[k] if numeric else v) for k, v in F_SYMBOLS.items()}
        if self.variant == "paper":
            return f["f5"] - f["f4"], 2 * f["f6"]
        return f["f5"], f["f4"] + 2 * f["f6"] - f["f7"]

    def power_terms(self, equation: int, numeric: bool = True) -> tuple[PowerTerm, ...]:
        """Terms of equation 1 or 2 grouped by power of A (Eq. 23's inner sums); computed once."""
        key = (equation, numeric)
        if key not in self._memo:
            self._memo[key] = self._power_terms(equation, numeric)
        return self._memo[key]

    def _power_terms(self, equation: int, numeric: bool) -> tuple[PowerTerm, ...]:
        groups: dict[sympy.Rational, list[Term]] = {}
        for term in self.expansion.equation_terms(equation):
            groups.setdefault(term.power, []).append(term)
        out = []
        for power in sorted(groups):
            # one Add of all the terms (a running sum is quadratic: minutes for the 1089 terms of u^32 v^32)
            sym = sympy.Add(*(t.coefficient * integral_symbol(t.integral) for t in groups[power]))
            value = None
            if numeric:
                sym = sym.xreplace(self.params)
                num = sym.xreplace({integral_symbol(t.integral): sympy.Float(self.constants[t.integral], 17) for t in groups[power]})
                if not num.free_symbols:
                    value = float(num)
            out.append(PowerTerm(power, sympy.expand(sym), value))
        return tuple(out)

    def _forcing(self, equation: int, amplitude: sympy.Symbol, numeric: bool) -> sympy.Expr:
        total = sympy.Integer(0)
        for pt in self.power_terms(equation, numeric):
            coeff = sympy.Float(pt.value, 17) if (numeric and pt.value is not None) else pt.coefficient
            if numeric and pt.value is None:
                coeff = pt.coefficient.xreplace(
                    {integral_symbol(k): sympy.Float(v, 17) for k, v in self.constants.items() if not k.startswith("f")}
                )
            total += coeff * amplitude**pt.power
        return total

    def equations(self, numeric: bool = False) -> tuple[sympy.Expr, ...]:
        """(F1, F2) as sympy expressions (F1 alone for the 1d variant); = 0 is implied."""
        f = {k: (sympy.Float(self.constants[k], 17) if numeric else v) for k, v in F_SYMBOLS.items()}
        P = self.P
        if self.variant == "1d":
            F1 = f["f1"] * A_PREV**P - (2 * f["f2"] - f["f3"]) * A_I**P + EPS * self._forcing(1, A_I, numeric)
            return (F1,)
        F1 = (
            f["f1"] * A_PREV**P
            - 2 * f["f2"] * A_I**P
            + f["f3"] * A_NEXT**P
            + EPS * self._forcing(1, A_I, numeric)
        )
        alpha, beta = self.alpha_beta(numeric=False)
        if numeric:
            alpha, beta = (sympy.Float(x, 17) for x in self.alpha_beta(numeric=True))
        F2 = alpha * A_I**P - beta * A_NEXT**P + EPS * self._forcing(2, A_NEXT, numeric)
        return (F1, F2)

    def as_data(self) -> dict:
        """The map as data: contact power, alpha/beta, and per equation the power terms."""
        alpha, beta = self.alpha_beta()
        return {
            "variant": self.variant,
            "P": str(self.P),
            "alpha": alpha,
            "beta": beta,
            "equation1": [
                {"power": str(t.power), "coefficient": str(t.coefficient), "value": t.value}
                for t in self.power_terms(1)
            ],
            "equation2": [
                {"power": str(t.power), "coefficient": str(t.coefficient), "value": t.value}
                for t in self.power_terms(2)
            ],
        }
