"""The scaling symmetry of Eq. 1 (solvers/chain/scaling.py): extreme impact velocities."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pulsemap.solvers.chain.peaks import StopRules
from pulsemap.solvers.chain import scaling
from pulsemap.solvers.chain.dns import MIN_ATOL, MIN_RTOL, Chain, Integrator, OnSiteForce, simulate
from pulsemap.solvers.chain.errors import DNSInputError
from pulsemap.solvers.chain.scaling import FORCE_LIMIT, Scaling, ScalingError

N, CONTACTS = 40, (10, 25)


def damping(mu: float, first: int = 10) -> OnSiteForce:
    mask = (np.arange(1, N + 1) >= first).astype(float)
    return OnSiteForce(force=lambda x, v: -mu * mask * v, dforce_dx=lambda x, v: 0.0 * x,
                       dforce_dv=lambda x, v: -mu * mask + 0.0 * v, stiffness_hint=mu)


@pytest.mark.parametrize("n", [1.5, 2.5])
@pytest.mark.parametrize("v0", [1e-150, 1e-30, 1e-6, 1e6, 1e30, 1e150])
def test_unperturbed_runs_at_any_velocity_are_the_unit_run_rescaled(n, v0):
    unit = simulate(Chain(N, n, 1.0), CONTACTS, window="auto")
    res = simulate(Chain(N, n, v0), CONTACTS, window="auto")
    lam = v0 ** (2 / (n + 1))
    tau = lam ** ((1 - n) / 2)
    assert res.alive.all() and "rescaled" in res.stop_reason
    np.testing.assert_allclose(res.peaks / lam, unit.peaks, rtol=1e-13)
    np.testing.assert_allclose(res.peak_times / tau, unit.peak_times, rtol=1e-13)
    assert res.energy_initial == pytest.approx(v0 ** 2 / 2, rel=1e-13) and res.velocity == v0
    np.testing.assert_allclose(res.total_energy / v0 ** 2, unit.total_energy, rtol=1e-12)


def test_the_force_mapping_agrees_with_a_direct_run(monkeypatch):
    """Damped chain at v0 = 30 (inside float range either way): rescaled and direct runs agree."""
    force = damping(0.2)
    direct = simulate(Chain(N, 1.5, 30.0, force), CONTACTS,
                      integrator=Integrator(rtol=1e-11, atol=1e-13))  # 30 is in DIRECT_RANGE
    assert "rescaled" not in direct.stop_reason and direct.alive.all()
    monkeypatch.setattr(scaling, "DIRECT_RANGE", (0.1, 10.0))
    rescaled = simulate(Chain(N, 1.5, 30.0, force), CONTACTS,
                        integrator=Integrator(rtol=1e-11, atol=1e-13 / 30.0 ** 0.8))
    assert "rescaled" in rescaled.stop_reason
    np.testing.assert_allclose(rescaled.peaks, direct.peaks, rtol=1e-8)
    np.testing.assert_allclose(rescaled.peak_times, direct.peak_times, rtol=1e-8)
    assert direct.peaks[-1] < 0.95 * direct.peaks[0]  # the damping acted


def test_scaled_force_and_its_derivatives():
    """F'(X, V) = lam^-n F(lam X, v0 V); dF'/dX = lam^(1-n) F_x; dF'/dV = tau F_v (cubic in u, linear in v)."""
    f = OnSiteForce(force=lambda x, v: 2.0 * x ** 3 - 0.5 * v, dforce_dx=lambda x, v: 6.0 * x ** 2 + 0 * v,
                    dforce_dv=lambda x, v: -0.5 + 0 * x, stiffness_hint=3.0)
    s = Scaling(1.5, 7.0)
    lam, tau = s.lam, s.tau
    X, V = np.array([0.3, -1.1]), np.array([0.7, 0.2])
    g = s.force(f)
    np.testing.assert_allclose(g.force(X, V), 2.0 * lam ** (3 - 1.5) * X ** 3 - 0.5 * tau * V, rtol=1e-14)
    h = 1e-6
    np.testing.assert_allclose(g.dforce_dx(X, V), (g.force(X + h, V) - g.force(X - h, V)) / (2 * h), rtol=1e-7)
    np.testing.assert_allclose(g.dforce_dv(X, V), (g.force(X, V + h) - g.force(X, V - h)) / (2 * h), rtol=1e-7)
    assert g.stiffness_hint == pytest.approx(3.0 * tau)


def test_a_perturbed_chain_is_refused_where_its_unit_frame_force_is_too_large():
    force = damping(0.3)
    with pytest.raises(ScalingError) as info:
        simulate(Chain(N, 1.5, 1e-100, force), CONTACTS)
    message = str(info.value)
    assert "\n" not in message and f"limit {FORCE_LIMIT:g}" in message
    lo = float(message.split("v0 in [")[1].split(",")[0])
    # damping mu in the unit frame is mu * tau = mu * v0^(-1/5) (n = 3/2): the limit at v0 = (0.3 / 1e8)^5
    assert lo == pytest.approx((0.3 / FORCE_LIMIT) ** 5, rel=1e-6)
    simulate(Chain(N, 1.5, lo * 1.01, force), (10, 11), stop=StopRules(max_steps=50))  # inside: accepted (and bounded)
    with pytest.raises(ScalingError):
        simulate(Chain(N, 1.5, lo / 1.01, force), (10, 11))


@pytest.mark.parametrize("v0", [1e-300, 1e300, 1e-151, 1e151])
def test_velocities_whose_energy_is_not_a_float_are_refused_with_the_range(v0):
    with pytest.raises(ValueError, match=r"outside \[1e-150, 1e\+150\]"):
        simulate(Chain(N, 1.5, v0), CONTACTS)


@pytest.mark.parametrize("rtol", [1e-300, 1e-16, MIN_RTOL / 2])
def test_a_tolerance_float64_cannot_deliver_is_refused(rtol):
    with pytest.raises(ValueError, match=f"rtol >= {MIN_RTOL:.2g}"):
        simulate(Chain(N, 1.5, 1.0), CONTACTS, integrator=Integrator(rtol=rtol))
    assert math.isclose(MIN_RTOL, 100 * np.finfo(float).eps)


@pytest.mark.parametrize("atol", [1e-300, 1e-160, MIN_ATOL / 2])
def test_an_atol_the_error_norm_cannot_square_is_refused(atol):
    with pytest.raises(DNSInputError, match=f"atol >= {MIN_ATOL:g}"):
        Integrator(atol=atol)


@pytest.mark.parametrize("engine, method", [("compiled", "RK45"), ("compiled", "DOP853"), ("scipy", "DOP853")])
def test_the_smallest_atol_taken_still_runs_to_the_last_contact(engine, method):
    """At MIN_ATOL every engine's error norm stays in float64 and the bare chain's pulse arrives as at atol 1e-12."""
    tight = simulate(Chain(N, 1.5, 1.0), CONTACTS, integrator=Integrator(rtol=1e-6, atol=MIN_ATOL, engine=engine,
                                                                        method=method))
    plain = simulate(Chain(N, 1.5, 1.0), CONTACTS, integrator=Integrator(rtol=1e-6, engine=engine, method=method))
    assert tight.stop_reason == "last contact peaked" and tight.engine == engine
    np.testing.assert_allclose(tight.peaks, plain.peaks, rtol=1e-5)
