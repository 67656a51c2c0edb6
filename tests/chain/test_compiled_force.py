"""The on-site force inside the compiled kernels (solvers/chain/compiled_force.py), paper Eq. 1.

A polynomial R reaches the kernels in one of two forms: its dense form P_0(u) + v P_1(u) (two cubics
by Horner, when every monomial u^a v^b has a <= 3 and b <= 1) or the general monomial table. Both
must be the same force: checked bead by bead on random states and per-bead coefficients (force and
its slopes, to round-off), and a run that needs the general table (u^5, v^3) against the scipy engine.
"""

from __future__ import annotations

import numpy as np

from pulsemap.solvers.chain.contact_force import kernel_terms
import pytest

from pulsemap.solvers.chain.window import WindowSpec
from pulsemap.solvers.chain.force_table import MonomialTable
from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.data.scene import load_scene, with_overrides
from pulsemap.solvers.studies.extent import dns_span
from pulsemap.solvers.studies.scene_chain import make_force

W, N = 7, 1.5
DENSE_EXPONENTS = [[0, 1], [1, 0], [2, 1], [3, 0], [3, 1], [2, 0], [1, 1]]


def random_table(rng, exponents, columns: int = 5) -> MonomialTable:
    return MonomialTable.of(exponents, rng.normal(size=(len(exponents), columns)))


def window_rhs(table_args, y, lo: int) -> np.ndarray:
    from pulsemap.solvers.chain.compiled_ops import rhs

    out = np.empty_like(y)
    rhs(0.3, y, out, W, lo, N, True, 0.4, 0.7, 0.1, True, *table_args, kernel_terms(None, None))
    return out


def test_dense_form_is_the_table_bead_by_bead():
    """RHS (Eq. 1 on a window with a coasting left bead and a wall) with the dense form equals the one
    with the monomial loop, for windows that start before, on and past the last stored column."""
    rng = np.random.default_rng(7)
    for trial in range(4):
        table = random_table(rng, DENSE_EXPONENTS[: 2 + trial])
        exps, dense = table.kernel_args
        assert dense.shape == (2, 4, table.coefficients.shape[1])
        for lo in (0, 2, 4, 9):
            y = rng.normal(size=2 * W)
            general = window_rhs((table.exponents, table.coefficients), y, lo)
            np.testing.assert_allclose(window_rhs((exps, dense), y, lo), general, rtol=1e-13, atol=1e-13)


def eq1_in_numpy(t, y, lo, n, left, wall, table, masses):
    """Eq. 1 on the window written out in numpy: the coasting left bead (``left``: x, v, t0, or None) and the wall
    at rest as two more beads, the on-site force of ``table`` (its last column for every later bead), masses."""
    x, v = y[0::2], y[1::2]
    xs = np.concatenate([[left[0] + left[1] * (t - left[2])] if left else [], x, [0.0] if wall else []])
    d = xs[:-1] - xs[1:]
    push = np.where(d > 0.0, np.maximum(d, 0.0) ** n, 0.0)
    behind = np.concatenate([[0.0] if not left else [], push])[:W]
    ahead = np.concatenate([push[1:] if left else push, [0.0] if not wall else []])[:W]
    cols = np.minimum(lo + np.arange(W), table.coefficients.shape[1] - 1)
    onsite = sum(table.coefficients[m, cols] * x**a * v**b for m, (a, b) in enumerate(table.exponents))
    out = np.empty_like(y)
    out[0::2], out[1::2] = v, (behind - ahead + onsite) / masses[lo: lo + W]
    return out


@pytest.mark.parametrize("n", [1.5, 2.5, 1.1])
@pytest.mark.parametrize("dense", [True, False])
def test_window_rhs_is_eq1_in_numpy(n, dense):
    """The kernels' right-hand side (compiled_ops.rhs: the Hertz power as a constant when n = 1.5, the force's
    uniform tail read once, the last bead apart) is Eq. 1 in numpy, on windows that start before, on and past the
    table's last column, with and without the coasting left bead and the wall, open and closed contacts, unit
    masses (the bare form) and random ones, both force forms."""
    from pulsemap.solvers.chain.compiled_ops import rhs

    rng = np.random.default_rng(3)
    table = random_table(rng, DENSE_EXPONENTS if dense else [[1, 0], [0, 1], [4, 0], [0, 3]])
    args = table.kernel_args if dense else (table.exponents, table.coefficients)
    assert (args[1].ndim == 3) == dense
    for trial, lo in enumerate((0, 2, 4, 9)):
        y = rng.normal(size=2 * W) * 0.3  # about half the contacts open
        left = (0.4, 0.7, 0.1) if trial % 2 == 0 else None
        wall = trial < 2
        for masses in (None, rng.uniform(0.5, 2.0, size=lo + W + 2)):
            out = np.empty_like(y)
            rhs(0.3, y, out, W, lo, n, left is not None, *(left or (0.0, 0.0, 0.0)), wall, *args,
                kernel_terms(None, masses))
            want = eq1_in_numpy(0.3, y, lo, n, left, wall, table, np.ones(lo + W) if masses is None else masses)
            np.testing.assert_allclose(out, want, rtol=1e-12, atol=1e-14)


def test_dense_slopes_are_the_tables():
    """The Rosenbrock kernel's banded Jacobian (dF/dx, dF/dv on its diagonal) is the same in both forms."""
    from pulsemap.solvers.chain.compiled_stiff import jacobian

    rng = np.random.default_rng(11)
    table = random_table(rng, DENSE_EXPONENTS)
    y = rng.normal(size=2 * W)
    bands = []
    for args in ((table.exponents, table.coefficients), table.kernel_args):
        band = np.zeros((7, W + 1))
        jacobian(0.3, y, W, 3, N, True, 0.4, 0.7, 0.1, True, *args, kernel_terms(None, None), band)
        bands.append(band.copy())
    np.testing.assert_allclose(bands[1], bands[0], rtol=1e-13, atol=1e-13)
    assert np.any(bands[0] != 0.0)


@pytest.mark.parametrize("exponents, dense", [([[1, 0], [0, 1], [2, 1]], True), ([[4, 0]], False),
                                              ([[0, 2]], False), ([[1, 0], [0, 3]], False)])
def test_dense_form_only_where_it_fits(exponents, dense):
    table = random_table(np.random.default_rng(1), exponents)
    exps, coef = table.kernel_args
    assert np.array_equal(exps, table.exponents)
    assert (coef.ndim == 3) == dense
    if dense:  # each monomial's coefficients land on its (b, a) row, every column
        for m, (a, b) in enumerate(table.exponents):
            np.testing.assert_array_equal(coef[b, a], table.coefficients[m])
    assert MonomialTable.zero().kernel_args[1].shape == (0, 1)  # R = 0: nothing to evaluate


def test_general_table_runs_agree_with_scipy():
    """An R the dense form cannot hold (u^5 and v^3) runs the monomial loop; its peaks equal the
    independent scipy engine's to 1e-7 on every live contact."""
    scene = with_overrides(load_scene("fig8-eps0.1"), R="-mu*v - 0.5*u^5 - 0.2*v^3")
    beads, span = dns_span(scene)
    force = make_force(scene, beads)
    assert force.monomials.kernel_args[1].ndim == 2 and force.monomials.describe == "monomial table"
    args = (Chain(beads, scene.exponent, scene.velocity, force), (span[0], min(span[1], 60)))
    fast = simulate(*args, integrator=Integrator(rtol=1e-10, atol=1e-12), window=WindowSpec(accuracy=1e-8))
    ref = simulate(*args, integrator=Integrator(engine="scipy", method="DOP853", rtol=1e-11, atol=1e-13),
                   window=WindowSpec(accuracy=1e-8))
    assert fast.engine == "compiled" and np.array_equal(fast.alive, ref.alive) and fast.alive.sum() >= 10
    assert fast.engine_reason.endswith(", monomial table")
    assert np.max(np.abs(fast.peaks[fast.alive] / ref.peaks[ref.alive] - 1.0)) < 1e-7


def test_kernel_loops_compile_without_reference_counting_where_numba_can():
    """compiled_ops.NO_NRT takes numba's private _nrt flag only where this numba knows it (an unknown
    option would fail at the first call, not at import)."""
    from numba.core.cpu import CPUTargetOptions

    from pulsemap.solvers.chain.compiled_ops import NO_NRT

    assert NO_NRT["cache"] is True
    assert ("_nrt" in NO_NRT) == hasattr(CPUTargetOptions, "_nrt")
