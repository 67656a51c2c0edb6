"""The compiled wave and right-hand side of the dressed law's expansion (models/dressed_kernel.py) against
the profile's own interpolant (derive/profile.py) and against the equations written out with numpy."""

from __future__ import annotations

import numpy as np
import pytest

from pulsemap.symbolic.profile import NPU, exact_profile
from pulsemap.solvers.models.dressed_expansion import WaveBase
from pulsemap.solvers.models.dressed_kernel import expansion_rhs

N, BEADS, CENTRE = 1.5, 24, 6


def test_the_wave_is_the_profile_at_each_contact():
    """d0_j(t) = S(t + centre - j) (contacts from 1), x0 and v0 the sums of strains and strain rates behind."""
    prof, base = exact_profile(N), WaveBase(N, BEADS, CENTRE)
    for t in np.linspace(-2.0, 14.0, 23):
        d0, x0, v0 = base(t)
        tau = t + CENTRE - np.arange(1, BEADS)
        inside = (tau >= prof.tau0) & (tau <= prof.tau0 + (prof.nodes.shape[0] - 1) * prof.h)
        np.testing.assert_allclose(d0[inside], np.maximum(prof.S(tau[inside]), 0.0), rtol=0, atol=1e-13)
        np.testing.assert_allclose(np.diff(-x0)[inside], d0[inside], rtol=0, atol=1e-13)
        np.testing.assert_allclose(-np.diff(v0)[inside], prof.dS(tau[inside]), rtol=0, atol=1e-12)
        assert np.all(d0[~inside] == 0.0)
    assert NPU * prof.h == pytest.approx(1.0)


def _numpy_rhs(t, Y, base, nn, floor, mask, monos, pairs):
    """The expansion's equations (models/dressed_expansion.py's docstring) with numpy arrays, term by term."""
    M, P = len(monos), len(pairs)
    Y = Y.reshape(2 * (M + P), BEADS)
    d0, x0, v0 = base(t)
    F1 = nn * d0 ** (nn - 1)
    F2 = nn * (nn - 1) * d0**nn / (d0 + floor) ** 2 if floor else nn * (nn - 1) * d0 ** (nn - 2)  # untapered: n >= 2

    def force(k, strain):
        acc = np.zeros(BEADS)
        acc[1:] += k * strain
        acc[:-1] -= k * strain
        return acc

    def grad(a, b):
        return (a * x0 ** max(a - 1, 0) * v0**b if a else 0 * x0, b * x0**a * v0 ** max(b - 1, 0) if b else 0 * x0)

    out = np.empty_like(Y)
    out[0::2] = Y[1::2]
    eta = [Y[2 * j, :-1] - Y[2 * j, 1:] for j in range(M)]
    for j, (a, b) in enumerate(monos):
        out[2 * j + 1] = force(F1, eta[j]) + mask * x0**a * v0**b
    for q, (j, l) in enumerate(pairs):
        z = Y[2 * (M + q)]
        (duj, dvj), (dul, dvl) = grad(*monos[j]), grad(*monos[l])
        lin = duj * Y[2 * l] + dvj * Y[2 * l + 1] + ((dul * Y[2 * j] + dvl * Y[2 * j + 1]) if j != l else 0)
        w = 0.5 if j == l else 1.0
        out[2 * (M + q) + 1] = force(F1, z[:-1] - z[1:]) + force(w * F2, eta[j] * eta[l]) + mask * lin
    return out.ravel()


@pytest.mark.parametrize("n, tapered", [(N, True), (2.5, False)])  # F'' tapered below the cut (n < 2) or not
@pytest.mark.parametrize("monos, pairs", [(((0, 1),), ((0, 0),)), (((1, 0), (2, 1)), ((0, 0), (0, 1), (1, 1)))])
def test_the_compiled_right_hand_side_is_the_expansion(monos, pairs, n, tapered):
    base = WaveBase(n, BEADS, CENTRE)
    rng = np.random.default_rng(3)
    mask = (np.arange(BEADS) >= 10).astype(float)
    floor = 1e-3 * exact_profile(n).S0 if tapered else 0.0
    M, P = len(monos), len(pairs)
    for t in (0.3, 2.71, 7.9):
        Y = rng.normal(size=2 * (M + P) * BEADS)
        got = expansion_rhs(t, Y, base.nodes, base.h, base.tau0, CENTRE, NPU, base.coef, BEADS, n, floor, mask,
                            np.array(monos, dtype=np.int64), np.array(pairs, dtype=np.int64))
        want = _numpy_rhs(t, Y, base, n, floor, mask, monos, pairs)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
        assert np.any(got[2 * M * BEADS:] != 0)  # the second order is exercised
