"""The exact-soliton launch: without on-site force every peak is A S(0) (Eqs. 4, 7, 32)."""

import numpy as np
import pytest

from pulsemap.symbolic.profile import exact_profile
from pulsemap.solvers.chain.equations import energy
from pulsemap.solvers.chain.launch import launch, min_centre, soliton_state


@pytest.mark.parametrize("n, A", [(1.5, 1.0), (1.5, 0.3), (2.0, 0.7)])
def test_launched_soliton_keeps_its_peak(n, A):
    S0 = exact_profile(n).S0
    r = launch(60, n, A, min_centre(n) + 1, (min_centre(n) + 3, 50))
    peaks = np.array(r.peaks, dtype=float)
    assert np.all(np.isfinite(peaks))
    assert np.max(np.abs(peaks / (A * S0) - 1)) < 1e-9
    # peak times advance by the delay A^-s between contacts (erratum 4, docs/errata.rst)
    gaps = np.diff(np.array(r.times))
    assert np.allclose(gaps, A ** (-(n - 1) / 2), rtol=1e-8)


def test_launched_state_carries_the_wave_energy():
    """E = E_1 A^(n+1), E_1 = 2.8234866884 (n = 3/2, virial and quadrature in tests/derive)."""
    from pulsemap.symbolic.balance import balance_constants

    c = balance_constants(["K1", "V1"], n=1.5)
    A = 0.8
    y = soliton_state(60, 1.5, A, 20)
    assert energy(y[0::2], y[1::2], 1.5) == pytest.approx((c["K1"].value + c["V1"].value) * A**2.5, rel=1e-9)


def test_bad_launch_arguments():
    with pytest.raises(ValueError, match="centre"):
        soliton_state(60, 1.5, 1.0, 2)
    with pytest.raises(ValueError, match="A must be"):
        soliton_state(60, 1.5, -1.0, 20)
    with pytest.raises(ValueError, match="contacts"):
        launch(60, 1.5, 1.0, 20, (10, 30))
