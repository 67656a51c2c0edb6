"""The contact law's term and the bead masses as the DNS engines take them (data, no sympy).

    m_i x_i'' = F(d_(i-1), w_(i-1)) - F(d_i, w_i) + F_i(x_i, x_i'),
    F(d, w) = H(d) (d^n + eps_c P_k(d, w)),  d_k = x_k - x_(k+1),  w_k = d_k'

``ContactTable``: eps_c P_k(d, w) = sum_m coef[m, k] d^(a_m) w^(b_m) (contact k 0-based; the last
column serves every contact after it), made from a scene's contact law (derive/contact_law.py).
``Masses`` of a Chain are a float64 array of the masses of beads 1..N. ``kernel_terms`` turns both into
the compiled kernels' three arrays (compiled_force.py: the bare form when there is neither).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pulsemap.solvers.chain.errors import DNSInputError

Array = np.ndarray


@dataclass(frozen=True, eq=False)
class ContactTable:
    """eps_c P_k(d, w) as data: ``exps`` (M, 2) [a_m >= 0, whole b_m >= 0], ``coef`` (M, L) per contact
    (0-based; column min(k, L - 1)), eps folded in. One-line ValueErrors naming the problem."""

    exps: Array
    coef: Array

    def __post_init__(self) -> None:
        exps = np.ascontiguousarray(self.exps, dtype=np.float64).reshape(-1, 2)
        coef = np.ascontiguousarray(self.coef, dtype=np.float64)
        if coef.ndim == 1:
            coef = coef.reshape(-1, 1)
        if coef.ndim != 2 or coef.shape[0] != exps.shape[0] or coef.shape[1] < 1:
            raise DNSInputError(f"a ContactTable's coef must have one row per exponent pair and at least one column, "
                                 f"got exps {exps.shape} and coef {coef.shape}")
        if not (np.all(np.isfinite(exps)) and np.all(np.isfinite(coef))):
            raise DNSInputError("a ContactTable's exponents and coefficients must be finite")
        a, b = exps[:, 0], exps[:, 1]
        if np.any(a < 0) or np.any(b < 0) or np.any(b != np.round(b)):
            raise DNSInputError("a ContactTable takes terms d^a w^b with a >= 0 and whole b >= 0")
        if np.any((a == 0) & (b == 0) & np.any(coef != 0, axis=1)):
            raise DNSInputError("a ContactTable term d^0 w^0 is a force at zero overlap: the chain starts at rest")
        object.__setattr__(self, "exps", exps)
        object.__setattr__(self, "coef", coef)

    def damping(self, exponent: float, strain: float = 1.0) -> float:
        """The largest over the contacts of sum |eps_c c| strain^(a + b (n+1)/2 - n) over the dissipative terms (odd
        b): their force against d^n on a wave of strain scale ``strain`` (w ~ strain^((n+1)/2); a dashpot weighs
        more on a weaker wave); the moving window's measure of what a damped pulse leaves behind (window.damped_behind)."""
        odd = self.exps[:, 1] % 2 == 1
        if not odd.any():
            return 0.0
        a, b = self.exps[odd, 0], self.exps[odd, 1]
        weight = float(strain) ** (a + b * (exponent + 1.0) / 2.0 - exponent)
        return float(np.max(np.sum(np.abs(self.coef[odd]) * weight[:, None], axis=0)))

    def _columns(self, k: Array) -> Array:
        return self.coef[:, np.minimum(k, self.coef.shape[1] - 1)]

    def value(self, d: Array, w: Array, k: Array) -> Array:
        """eps_c P_k(d, w) for overlaps d > 0, rates w and 0-based contacts k (arrays of one shape)."""
        c = self._columns(k)
        out = np.zeros(np.shape(d))
        for m, (a, b) in enumerate(self.exps):
            out += c[m] * d**a * w ** int(b)
        return out


def check_masses(masses: object, beads: int) -> Array | None:
    """The masses of beads 1..beads as float64 (None: all 1), or a one-line ValueError."""
    if masses is None:
        return None
    m = np.ascontiguousarray(masses, dtype=np.float64)
    if m.ndim != 1 or m.size != beads:
        raise DNSInputError(f"masses must list one mass per bead ({beads}), got shape {m.shape}")
    bad = np.flatnonzero(~(np.isfinite(m) & (m > 0.0)))
    if bad.size:
        j = int(bad[0])
        raise DNSInputError(f"the mass of bead {j + 1} is {m[j]!r}: masses must be finite and > 0")
    return m


def kernel_terms(contact: ContactTable | None, masses: Array | None) -> Array:
    """The compiled kernels' ``ct`` (compiled_force.py's layout): the bare form (a 1-d array) for the Hertz chain
    of unit masses, else one table (1 + M, 2 + L): row 0 the inverse masses from column 2, row 1 + m the exponents
    a_m, b_m and from column 2 the per-contact coefficients; a shorter row keeps its last value (a uniform tail)."""
    if contact is None and masses is None:
        return np.zeros(0)
    coef = np.zeros((0, 1)) if contact is None else contact.coef
    exps = np.zeros((0, 2)) if contact is None else contact.exps
    inverse = np.ones(1) if masses is None else 1.0 / np.asarray(masses, float)
    width = max(coef.shape[1], inverse.size)
    ct = np.zeros((1 + coef.shape[0], 2 + width))
    ct[0, 2:] = np.concatenate([inverse, np.full(width - inverse.size, inverse[-1])])
    ct[1:, :2] = exps
    if coef.shape[0]:
        ct[1:, 2:] = np.concatenate([coef, np.repeat(coef[:, -1:], width - coef.shape[1], axis=1)], axis=1)
    return ct
