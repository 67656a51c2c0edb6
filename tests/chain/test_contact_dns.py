"""The DNS with a contact law's term eps_c P_k(d, w) and bead masses: every engine against the others, the
uniform-mass time scaling, energy with masses, and the run's outputs."""

from __future__ import annotations

import numpy as np
import pytest

from pulsemap.solvers.chain.contact_force import ContactTable, check_masses, kernel_terms
from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.chain.plan import Plan

N, FIRST, LAST = 70, 16, 50


def dashpot(c: float, a: float = 0.0, beads: int = N) -> ContactTable:
    """eps_c c d^a w on contacts >= FIRST."""
    coef = np.zeros((1, beads - 1))
    coef[0, FIRST - 1:] = c
    return ContactTable(np.array([[a, 1.0]]), coef)


def peaks(chain: Chain, **kw) -> np.ndarray:
    res = simulate(chain, (FIRST, LAST), **kw)
    assert res.stop_reason == "last contact peaked", res.stop_reason
    return res.peaks


@pytest.mark.slow  # compiles the DOP853 kernel for contact terms
@pytest.mark.parametrize("a", [0.0, 0.5])
def test_every_engine_gives_the_same_damped_peaks(a):
    """Dashpot (a = 0) and Kuwabara-Kono (a = 1/2) contacts: compiled RK45 and DOP853 on the moving window,
    compiled Rodas4 and the scipy engine on the full chain agree to their tolerance, and the pulse decays."""
    chain = Chain(N, 1.5, 1.0, contact=dashpot(0.05, a))
    ref = peaks(chain, integrator=Integrator(method="DOP853", rtol=1e-10, engine="scipy"))
    assert np.all(np.diff(ref) < 0) and ref[-1] < 0.9 * ref[0]
    for method, window in (("RK45", "auto"), ("DOP853", "auto"), ("RK45", None)):
        got = peaks(chain, integrator=Integrator(method=method, rtol=1e-10), window=window)
        np.testing.assert_allclose(got, ref, rtol=1e-7)


@pytest.mark.slow  # compiles the Rodas4 kernel for contact terms
def test_the_stiff_kernel_takes_damped_contacts_and_masses():
    """Rodas4 (compiled) with a dashpot on a taper agrees with the scipy engine's Radau."""
    masses = np.ones(N)
    masses[FIRST - 1:] = 1.0 + 0.01 * np.arange(N - FIRST + 1)
    from pulsemap.solvers.chain import compiled

    chain = Chain(N, 1.5, 1.0, contact=dashpot(0.3), masses=masses)
    ref = peaks(chain, integrator=Integrator(method="Radau", rtol=1e-10, engine="scipy"))
    run = compiled.prepare(chain, (FIRST, LAST), None, Plan("compiled", "Rodas4", None, "", ""),
                           Integrator(rtol=1e-9, atol=1e-12), _rules())
    kernel = compiled.kernel_for(run)[0]
    compiled.drive(run, kernel)
    got = compiled.result(run, compiled.K.LAST_PEAKED, 0.0)
    np.testing.assert_allclose(got.peaks, ref, rtol=1e-6)


def _rules():
    from dataclasses import replace

    from pulsemap.solvers.chain.equations import default_max_steps, default_t_max
    from pulsemap.solvers.chain.peaks import StopRules

    return replace(StopRules(), t_max=default_t_max(LAST, 1.0, 1.5), max_steps=default_max_steps(LAST))


def test_uniform_masses_rescale_time():
    """m x'' = F on every bead is the unit chain in t / sqrt(m): the same strain peaks at v0 sqrt(m), at
    peak times sqrt(m) later."""
    m = 2.25
    heavy = simulate(Chain(N, 1.5, 1.0, masses=np.full(N, m)), (FIRST, LAST), window="auto")
    unit = simulate(Chain(N, 1.5, np.sqrt(m)), (FIRST, LAST), window="auto")
    np.testing.assert_allclose(heavy.peaks, unit.peaks, rtol=1e-8)
    np.testing.assert_allclose(heavy.peak_times, unit.peak_times * np.sqrt(m), rtol=1e-8)


def test_a_taper_conserves_energy_with_its_masses():
    """Masses alone do no work: the energy sum m v^2/2 + contacts is conserved to the tolerance (full
    chain) and the compiled and scipy engines agree."""
    masses = np.ones(N)
    masses[FIRST - 1:] = 1.0 + 0.02 * np.arange(N - FIRST + 1)
    chain = Chain(N, 1.5, 1.0, masses=masses)
    res = simulate(chain, (FIRST, LAST))
    assert res.energy_drift is not None and res.energy_drift < 1e-7
    ref = peaks(chain, integrator=Integrator(method="DOP853", rtol=1e-10, engine="scipy"))
    np.testing.assert_allclose(res.peaks, ref, rtol=1e-7)
    unit = peaks(Chain(N, 1.5, 1.0))
    assert abs(res.peaks[-1] / unit[-1] - 1.0) < 0.05  # first order: the strain peak barely moves


def test_the_bare_form_is_chosen_only_for_the_hertz_chain_of_unit_masses():
    assert kernel_terms(None, None).ndim == 1
    assert kernel_terms(None, np.ones(3)).ndim == 2
    assert kernel_terms(dashpot(0.1), None).ndim == 2


@pytest.mark.parametrize("masses, message", [(np.array([1.0, -1.0, 1.0]), "bead 2"), (np.array([1.0, np.nan, 1.0]), "bead 2"),
                                             (np.ones(4), "one mass per bead")])
def test_bad_masses_are_refused_naming_the_bead(masses, message):
    with pytest.raises(ValueError, match=message):
        check_masses(masses, 3)


def test_a_force_at_zero_overlap_is_refused():
    with pytest.raises(ValueError, match="zero overlap"):
        ContactTable(np.array([[0.0, 0.0]]), np.ones((1, 3)))
    with pytest.raises(ValueError, match="whole b"):
        ContactTable(np.array([[1.0, 0.5]]), np.ones((1, 3)))


def test_bead_velocity_peaks_are_each_beads_velocity_maximum():
    """With masses the compiled engine records each bead's first velocity maximum: on a taper (where the leading
    pulse carries every bead's largest velocity) it is the maximum of v_b over scipy's dense solution."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import minimize_scalar

    from pulsemap.solvers.chain.equations import initial_state, make_rhs

    masses = np.ones(N)
    masses[FIRST - 1:] = 1.0 + 0.01 * np.arange(N - FIRST + 1)
    res = simulate(Chain(N, 1.5, 1.0, masses=masses), (FIRST, LAST), integrator=Integrator(method="RK45", rtol=1e-11))
    vpk = res.velocity_peaks
    assert vpk is not None and vpk.size == LAST + 1 and vpk[0] == 1.0
    sol = solve_ivp(make_rhs(N, 1.5, None, terms=(None, masses)), (0.0, res.t_end), initial_state(N, 1.0),
                    method="DOP853", rtol=1e-12, atol=1e-14, dense_output=True)
    grid = np.linspace(0.0, res.t_end, 40001)
    for bead in (FIRST - 5, FIRST, FIRST + 10, LAST - 2):
        v = sol.sol(grid)[2 * bead - 1]
        j = int(np.argmax(v))
        best = minimize_scalar(lambda t: -sol.sol(t)[2 * bead - 1], bounds=(grid[j - 1], grid[j + 1]), method="bounded",
                               options={"xatol": 1e-10})
        assert vpk[bead - 1] == pytest.approx(-best.fun, rel=1e-8)
    assert np.all(np.diff(vpk[FIRST:LAST]) < 0)  # heavier beads move slower
    bare = simulate(Chain(N, 1.5, 1.0), (FIRST, LAST))
    assert bare.velocity_peaks is None
