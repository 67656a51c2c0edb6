"""Non-smooth R: sign, Heaviside, abs run in the DNS; map, law and balances refuse them."""

import numpy as np
import pytest

from pulsemap.solvers.chain.peaks import StopRules
from pulsemap.symbolic.balance import BalanceError, balance_expand
from pulsemap.symbolic.codegen_force import DELTA
from pulsemap.symbolic.expansion import ExpansionError, expand
from pulsemap.symbolic.expression import parse_expression
from pulsemap.solvers.chain.dns import Chain, simulate
from pulsemap.solvers.chain.equations import OnSiteForce, choose_method
from pulsemap.solvers.models.codeload import force_module

X = np.array([-0.5, -1e-3, -DELTA / 4, 0.0, DELTA / 2, 2e-9, 0.3])


@pytest.mark.parametrize("R, exact", [
    ("-mu*sign(v)", lambda x, v, mu: -mu * np.sign(v)),
    ("-mu*sign(u)*u^2", lambda x, v, mu: -mu * np.sign(x) * x**2),
    ("mu*Heaviside(u)*u", lambda x, v, mu: mu * (x > 0) * x),
    ("-mu*abs(v)*v", lambda x, v, mu: -mu * np.abs(v) * v),
])
def test_the_force_is_the_formula_outside_the_ramp_and_its_jacobian_its_slope(R, exact):
    mod = force_module(R, ["mu"])
    x, v = X, X[::-1].copy()
    i, eps = np.arange(1.0, 8.0), np.full(7, 0.1)
    outside = (np.abs(x) >= DELTA) & (np.abs(v) >= DELTA)
    got = mod.force(x, v, i, eps, 0.7)
    assert np.all(np.isfinite(got))
    assert np.allclose(got[outside], 0.1 * exact(x, v, 0.7)[outside], rtol=1e-14, atol=0)
    # the Jacobian is the derivative of the integrated force (central differences, away from the ramp's corners)
    for fn, dx, dv in (("force_dx", 1, 0), ("force_dv", 0, 1)):
        h = DELTA / 100
        fd = (mod.force(x + dx * h, v + dv * h, i, eps, 0.7) - mod.force(x - dx * h, v - dv * h, i, eps, 0.7)) / (2 * h)
        corner = (np.abs(np.abs(x) - DELTA) < 2 * h) | (np.abs(np.abs(v) - DELTA) < 2 * h)
        assert np.allclose(getattr(mod, fn)(x, v, i, eps, 0.7)[~corner], fd[~corner], rtol=1e-6, atol=1e-6 / DELTA * 1e-9)


def test_coulomb_friction_dns_runs_loses_energy_and_the_pulse_dies():
    """-mu*sign(v): every bead the pulse moves loses eps*mu*(its displacement), so the energy only falls."""
    mod = force_module("-mu*sign(v)", ["mu"])
    beads, first = 60, 16
    idx = np.arange(1.0, beads + 1)
    eps = np.where(idx >= first, 0.05, 0.0)
    args = (idx, eps, 1.0)
    force = OnSiteForce(force=lambda x, v: mod.force(x, v, *args), dforce_dx=lambda x, v: mod.force_dx(x, v, *args),
                        dforce_dv=lambda x, v: mod.force_dv(x, v, *args),
                        stiffness_hint=float(np.max(np.abs(mod.force_dv(0 * idx, 0 * idx, *args)))))
    assert choose_method(force, 1.0, 1.5) == "LSODA"  # the ramp is stiff: 'auto' goes implicit
    run = simulate(Chain(beads, 1.5, 1.0, force), (first, 40), stop=StopRules(max_steps=200_000))
    live = np.isfinite(run.peaks)
    peaks = run.peaks[live]
    assert 6 <= live.sum() < len(run.peaks)  # the pulse decays to nothing at a finite contact
    assert np.all(np.diff(peaks) < 0) and np.all(peaks > 0)
    total = np.asarray(run.total_energy)[live]
    assert np.all(np.diff(total) <= 1e-12) and total[0] <= run.energy_initial + 1e-9
    pulse = np.asarray(run.pulse_energy)[live]
    assert np.all(np.diff(pulse) < 0)


@pytest.mark.parametrize("text", ["-mu*sign(v)", "mu*Heaviside(u)*u", "-mu*abs(v)*v", "-mu*v + sign(u)*u^2"])
def test_map_law_and_balances_refuse_non_smooth_R_with_the_reason(text):
    R = parse_expression(text, ["mu"])
    with pytest.raises(ExpansionError, match=r"not a polynomial in u, v \(.* has a kink or a jump at 0\).*DNS runs it"):
        expand(R)
    for model in ("energy", "momentum"):
        with pytest.raises(BalanceError, match="kink or a jump"):
            balance_expand(R, 1.5, model)
