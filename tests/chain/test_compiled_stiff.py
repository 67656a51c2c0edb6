"""The compiled Rosenbrock engine (solvers/chain/compiled_stiff.py, Rodas4) for stiff forces, paper Eq. 1.

Stated tolerance: on the suite's stiff scenes (stiffness hint > 30 x contact rate), at rtol 1e-9 the
compiled engine's leading-edge peaks agree with scipy's Radau (rtol 1e-11, its own moving window)
to STIFF_TOL relative on every live contact, with the same live contacts and the same stop rule;
at rtol 1e-7 they are at least 10x further off (convergence in the tolerance). The step itself is
fourth order (fixed steps against an independent Radau solution) and its Jacobian is Eq. 1's.
"""

from __future__ import annotations

import numpy as np

from pulsemap.solvers.chain.contact_force import ContactTable, kernel_terms
import pytest
from scipy.integrate import solve_ivp

from pulsemap.solvers.chain.force_table import MonomialTable
from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.data.scene import load_scene, with_overrides
from pulsemap.solvers.studies.extent import dns_span
from pulsemap.solvers.studies.scene_chain import make_force
from pulsemap.solvers.studies.suite import resolve

STIFF_TOL = 1e-7
ORDER_LOW = 3.7
RADAU = dict(engine="scipy", method="Radau", rtol=1e-11, atol=1e-13, window="auto")
STIFF_SCENES = ["damp-100", "damp-1000", "stiff-foundation"]
STIFFER = {"damp-100": dict(eps=1.0), "damp-1000": {}, "stiff-foundation": dict(eps=10.0)}  # hints 1000, 1000, 316


def rel(a, b) -> float:
    return float(np.max(np.abs(np.asarray(a) / np.asarray(b) - 1.0)))


def stiff_run(name: str, stiffer: bool = False, window=None, **kw):
    """The scene's chain and force from contact 1 (the unperturbed approach is integrated by the
    stiff method too) to 20 past the first perturbed bead: the strong on-site force kills the pulse.
    ``stiffer``: eps raised so that 'auto' takes Rodas4 on the compiled engine (STIFFER)."""
    scene = load_scene(resolve(name))
    if stiffer and STIFFER[name]:
        scene = with_overrides(scene, **STIFFER[name])
    beads, _ = dns_span(scene)
    return simulate(Chain(beads, scene.exponent, scene.velocity, make_force(scene, beads)), (1, scene.first_perturbed + 20),
                    integrator=Integrator(**kw), window=window)


@pytest.mark.parametrize("stiffer", [False, pytest.param(True, marks=pytest.mark.slow)], ids=["suite", "stiffer"])
@pytest.mark.parametrize("name", STIFF_SCENES)
def test_stiff_suite_scenes_agree_with_radau(name, stiffer):
    """'auto' takes Rodas4 above COMPILED_STIFFNESS_RATIO x the contact rate (the suite's damp-1000, and
    each scene made stiffer), Dormand-Prince below (the suite's damp-100 and stiff-foundation, where it is
    cheaper); either way the peaks converge to Radau's."""
    from pulsemap.solvers.chain.plan import is_stiff

    ref = stiff_run(name, stiffer, **RADAU)
    scene = with_overrides(load_scene(resolve(name)), **(STIFFER[name] if stiffer else {}))
    beads, _ = dns_span(scene)
    rosenbrock = is_stiff(make_force(scene, beads), scene.velocity, scene.exponent)
    assert rosenbrock == (stiffer or name == "damp-1000")
    err = {}
    for rtol in (1e-7, 1e-9):
        fast = stiff_run(name, stiffer, rtol=rtol, atol=rtol * 1e-2, window="auto")
        assert fast.engine == "compiled" and fast.mode == "window/compiled"
        if rosenbrock:
            assert fast.method == "Rodas4" and fast.njev >= fast.steps > 0
            assert fast.engine_reason.startswith("compiled Rosenbrock (Rodas4): stiffness hint")
        else:
            assert fast.method == "RK45" and "where it is cheaper than Rodas4" in fast.engine_reason
        assert np.array_equal(fast.alive, ref.alive) and fast.alive.sum() >= 10
        assert fast.stop_reason.split("(")[0] == ref.stop_reason.split("(")[0]
        err[rtol] = rel(fast.peaks[fast.alive], ref.peaks[ref.alive])
    assert err[1e-9] < STIFF_TOL
    assert err[1e-9] < 0.1 * err[1e-7]


def test_scipy_engine_still_runs_the_implicit_method_on_request():
    res = stiff_run("damp-1000", engine="scipy", window="auto", rtol=1e-6, atol=1e-8)
    assert res.engine == "scipy" and res.method == "LSODA"
    named = stiff_run("damp-1000", method="Radau", window="auto", rtol=1e-6, atol=1e-8)
    assert named.engine == "scipy" and "no compiled kernel" in named.engine_reason


# ---------------------------------------------------------------- the step on a small compressed window

W, N = 6, 1.5
LEFT = (0.7, 1.2, 0.0)  # coasting left bead: x = 0.7 + 1.2 t


#: The chain's contact-law term and masses in the small window: none; a dashpot and a Kuwabara-Kono term on
#: uneven masses (every contact of the window and the coasting bead's carry them).
TERMS = {"bare": (None, None),
         "dashpot, KK, masses": (ContactTable(np.array([[0.0, 1.0], [0.5, 1.0], [2.5, 0.0]]),
                                              np.array([[3.0, 2.0, 1.0], [1.5, 0.5, 2.0], [0.4, 0.2, 0.1]])),
                                 np.array([1.0, 1.3, 0.7, 2.0, 1.1, 0.9]))}


def small_window(mu: float, terms=(None, None)):
    """Six compressed beads (every contact stays closed), a coasting left bead and a wall; R = -mu v - 5 u;
    ``terms``: (contact, masses) of the window's beads (contact_force.kernel_terms)."""
    from pulsemap.solvers.chain.compiled_ops import rhs

    table = MonomialTable.of([[0, 1], [1, 0]], [[-mu], [-5.0]])
    y0 = np.zeros(2 * W)
    y0[0::2] = [0.55, 0.45, 0.35, 0.25, 0.15, 0.05]
    y0[1::2] = [1.0, 0.8, 0.5, 0.3, 0.1, 0.0]
    args = (table.exponents, table.coefficients, kernel_terms(*terms))

    def f(t, y):
        out = np.empty_like(y)
        rhs(t, y, out, W, 1, N, True, *LEFT, True, *args)
        return out

    return args, y0, f


@pytest.mark.parametrize("terms", TERMS)
def test_jacobian_and_linear_solve_are_eq1s(terms):
    """The banded Jacobian (contact stiffness, damping dF/dw, on-site slopes, masses) against central
    differences of the right-hand side, and the tridiagonal solve against a dense one."""
    from pulsemap.solvers.chain import compiled_stiff as S

    args, y0, f = small_window(30.0, TERMS[terms])
    band = np.empty((7, W + 1))
    t = 0.1
    ft = S.jacobian(t, y0, W, 1, N, True, *LEFT, True, *args, band)
    step = 1e-6
    fd = np.column_stack([(f(t, y0 + step * e) - f(t, y0 - step * e)) / (2 * step) for e in np.eye(2 * W)])
    s, g, mi = band[0], band[5], band[6]
    jac = np.zeros((2 * W, 2 * W))
    for j in range(W):
        jac[2 * j, 2 * j + 1] = 1.0
        jac[2 * j + 1, 2 * j] = (band[1, j] - s[j] - s[j + 1]) * mi[j]
        jac[2 * j + 1, 2 * j + 1] = (band[2, j] - g[j] - g[j + 1]) * mi[j]
        if j > 0:
            jac[2 * j + 1, 2 * j - 2] = s[j] * mi[j]
            jac[2 * j + 1, 2 * j - 1] = g[j] * mi[j]
        if j < W - 1:
            jac[2 * j + 1, 2 * j + 2] = s[j + 1] * mi[j]
            jac[2 * j + 1, 2 * j + 3] = g[j + 1] * mi[j]
    assert np.max(np.abs(jac - fd)) < 1e-6
    assert abs(ft - (f(t + step, y0) - f(t - step, y0))[1] / (2 * step)) < 1e-6
    hg = 0.01
    assert S.factor(hg, W, band, args[2])
    r, k = np.random.default_rng(0).normal(size=2 * W), np.empty(2 * W)
    S.solve(r, k, hg, W, band, args[2])
    np.testing.assert_allclose((np.eye(2 * W) / hg - jac) @ k, r, atol=1e-12)


@pytest.mark.parametrize("mu, terms", [(0.0, "bare"), (20.0, "bare"), (20.0, "dashpot, KK, masses")])
def test_rosenbrock_step_is_fourth_order(mu, terms):
    """Fixed steps h, h/2, ... against Radau at rtol 1e-13: the error falls 2^4 per halving."""
    from pulsemap.solvers.chain import compiled_stiff as S

    args, y0, f = small_window(mu, TERMS[terms])
    t_end = 0.4
    ref = solve_ivp(f, (0.0, t_end), y0, method="Radau", rtol=1e-13, atol=1e-15).y[:, -1]
    errors = []
    for m in (10, 20, 40, 80):
        h = t_end / m
        y, yn, err = y0.copy(), np.empty(2 * W), np.empty(2 * W)
        k, work, band = np.empty((S.STAGES, 2 * W)), np.empty((3, 2 * W)), np.empty((7, W + 1))
        for i in range(m):
            assert S.rosenbrock_step(i * h, h, y, f(i * h, y), yn, err, W, 1, N, True, *LEFT, True, *args, k, work, band)
            y = yn.copy()
        errors.append(np.max(np.abs(y - ref)))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(orders > ORDER_LOW) and orders[-1] < 4.3 and errors[-1] < 1e-8
