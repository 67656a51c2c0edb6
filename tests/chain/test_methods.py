"""The DNS method table (chain/methods.py): every registered compiled kernel integrates the same damped chain
to the scipy reference, every part reads the table, and a new method is one row."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pulsemap.solvers.chain import compiled, methods, plan
from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.chain.equations import default_max_steps, default_t_max
from pulsemap.solvers.chain.force_table import MonomialTable
from pulsemap.solvers.chain.peaks import StopRules
from pulsemap.solvers.data.scene.schema import DNS_METHODS

N, FIRST, LAST = 60, 16, 40


def _reference(table: MonomialTable) -> np.ndarray:
    from pulsemap.solvers.chain.equations import OnSiteForce

    coef = table.coefficients[0]
    force = OnSiteForce(lambda x, v: np.where(np.arange(N) >= FIRST - 1, coef[np.minimum(np.arange(N), coef.size - 1)], 0.0) * v,
                        monomials=table)
    return simulate(Chain(N, 1.5, 1.0, force), (FIRST, LAST),
                    integrator=Integrator(method="DOP853", rtol=1e-11, engine="scipy")).peaks


def _kernel_peaks(method: str, table: MonomialTable) -> np.ndarray:
    stop = replace(StopRules(), t_max=default_t_max(LAST, 1.0, 1.5), max_steps=default_max_steps(LAST))
    run = compiled.prepare(Chain(N, 1.5, 1.0), (FIRST, LAST), table, plan.Plan("compiled", method, None, "", ""),
                           Integrator(rtol=1e-10, atol=1e-12), stop)
    kernel = compiled.kernel_for(run)[0]
    code = compiled.drive(run, kernel)
    res = compiled.result(run, code, 0.0)
    assert res.stop_reason == "last contact peaked", res.stop_reason
    return res.peaks


@pytest.mark.parametrize("method", methods.names(kernel=True))
def test_every_registered_kernel_integrates_eq1(method):
    """Linear damping -0.05 v from bead 16: each kernel's peaks match scipy's DOP853 at rtol 1e-11."""
    coef = np.zeros((1, N))
    coef[0, FIRST - 1:] = -0.05
    table = MonomialTable.of([[0, 1]], coef)
    np.testing.assert_allclose(_kernel_peaks(method, table), _reference(table), rtol=2e-7)


def test_every_part_reads_the_table():
    from pulsemap.solvers.chain import compiled_aot, equations

    assert set(compiled_aot.methods.kernels()) == set(methods.names(kernel=True))
    assert equations.METHODS == DNS_METHODS == methods.selectable()
    assert "RK23" in DNS_METHODS and "Rodas4" not in DNS_METHODS  # the stiff kernel runs where 'auto' chooses it
    for name in methods.names(kernel=True):
        assert compiled.jit_kernel(name) is not None
    assert plan.STIFF_METHOD in methods.names(kernel=True, implicit=True)
    assert plan.METHOD in methods.names(kernel=True, implicit=False)


def test_a_new_kernel_is_one_row(monkeypatch):
    """A toy method registered by one row (here the RK45 kernel's module under a new name) is accepted by the
    Integrator, planned on the compiled engine, loaded and run."""
    toy = methods.DNSMethod("Toy45", "compiled_kernel", False, False, 5, "toy Dormand-Prince")
    monkeypatch.setattr(methods, "METHODS", methods.METHODS + (toy,))
    integrator = Integrator(method="Toy45", rtol=1e-9)
    how = plan.plan(engine="compiled", method="Toy45", force=None, velocity=1.0, exponent=1.5, rtol=1e-9, window=None)
    assert (how.engine, how.method) == ("compiled", "Toy45") and "toy Dormand-Prince" in how.reason
    res = simulate(Chain(N, 1.5, 1.0), (FIRST, LAST), integrator=integrator)
    ref = simulate(Chain(N, 1.5, 1.0), (FIRST, LAST), integrator=Integrator(method="RK45", rtol=1e-9))
    np.testing.assert_array_equal(res.peaks, ref.peaks)


def test_auto_picks_the_rows_marked_for_it():
    """Each role 'auto' chooses between is one row: compiled kernels for the compiled engine's, scipy solvers
    (implicit where the force is stiff) for the scipy engine's."""
    for role in methods.AUTO_ROLES:
        record = methods.by_name(methods.auto_pick(role))
        assert (record.scipy if role.startswith("scipy") else bool(record.kernel))
        assert record.implicit == (role not in ("explicit", "scipy explicit"))
    assert (plan.METHOD, plan.STIFF_METHOD) == (methods.auto_pick("explicit"), methods.auto_pick("stiff"))
