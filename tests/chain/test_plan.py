"""chain/plan.plan decides engine, kernel, window and method of a DNS run, without integrating anything."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from pulsemap.solvers.chain import plan as P
from pulsemap.solvers.chain.equations import STIFFNESS_RATIO
from pulsemap.solvers.chain.peaks import contact_rate
from pulsemap.solvers.chain.window import WindowRule, WindowSpec, rule_for_accuracy, rule_for_width

RATE = contact_rate(1.0, 1.5)


def force(ratio: float) -> SimpleNamespace:
    """A force whose stiffness hint is ``ratio`` x the contact rate at v0 = 1, n = 1.5."""
    return SimpleNamespace(stiffness_hint=ratio * RATE)


def make(**kw) -> P.Plan:
    args = dict(engine="compiled", method="auto", force=None, velocity=1.0, exponent=1.5, rtol=1e-10, window=None)
    return P.plan(**{**args, **kw})


def test_default_is_the_compiled_dormand_prince_on_the_full_chain():
    p = make()
    assert (p.engine, p.method, p.rule, p.window_engine) == ("compiled", "RK45", None, "")
    assert p.reason == "compiled RK45 (Dormand-Prince 5(4))"


@pytest.mark.parametrize("rtol, accuracy", [(1e-10, 1e-8), (1e-6, 1e-6), (1e-12, 1e-8)])
def test_window_auto_takes_the_accuracy_rule_of_the_looser_of_rtol_and_1e8(rtol, accuracy):
    assert make(window="auto", rtol=rtol).rule == rule_for_accuracy(accuracy)
    assert make(window=WindowSpec(accuracy=1e-9), rtol=rtol).rule == rule_for_accuracy(1e-9)


def test_window_width_and_rule_are_taken_as_given():
    assert make(window=40).rule == rule_for_width(40)
    rule = WindowRule(behind=30)
    assert make(window=rule).rule is rule
    with pytest.raises(ValueError, match="window"):
        make(window="wide")


@pytest.mark.parametrize("ratio", [0.0, STIFFNESS_RATIO * 2, P.COMPILED_STIFFNESS_RATIO * 0.99])
def test_auto_stays_explicit_below_the_compiled_stiffness_ratio(ratio):
    p = make(force=force(ratio))
    assert (p.engine, p.method) == ("compiled", "RK45")
    assert ("cheaper than Rodas4" in p.reason) == (ratio > STIFFNESS_RATIO)


def test_auto_takes_rodas4_above_it_and_says_why():
    p = make(force=force(P.COMPILED_STIFFNESS_RATIO * 1.01))
    assert (p.engine, p.method) == ("compiled", "Rodas4")
    assert p.reason.startswith("compiled Rosenbrock (Rodas4): stiffness hint")


def test_a_named_explicit_method_runs_its_kernel_even_for_a_stiff_force():
    p = make(force=force(1e4), method="DOP853")
    assert (p.engine, p.method) == ("compiled", "DOP853") and "'DOP853' requested" in p.reason
    assert make(force=force(1e4), method="RK45").method == "RK45"


@pytest.mark.parametrize("kw, why", [
    (dict(method="LSODA"), "method LSODA has no compiled kernel"),
    (dict(snapshots=True), "strain snapshots are recorded by the scipy engine only"),
    (dict(force_reason="R(0, 0) != 0"), "R(0, 0) != 0"),
    (dict(engine="scipy"), "engine='scipy' requested"),
])
def test_the_scipy_engine_runs_where_the_compiled_one_cannot_and_says_why(kw, why):
    p = make(**kw)
    assert p.engine == "scipy" and p.reason.startswith(why)


def test_scipy_auto_is_dop853_or_lsoda_for_a_stiff_force_on_the_fortran_window():
    assert make(engine="scipy").method == "DOP853"
    assert make(engine="scipy", force=force(STIFFNESS_RATIO * 1.01)).method == "LSODA"
    ramp = SimpleNamespace(stiffness_hint=STIFFNESS_RATIO * 1.01 * RATE, ramp=True)  # Coulomb's sign as a ramp
    assert make(engine="scipy", force=ramp).method == "BDF"
    win = make(engine="scipy", window="auto")
    assert (win.method, win.window_engine, win.rule) == ("DOP853", "fortran", rule_for_accuracy(1e-8))
    assert make(engine="scipy", window="auto", method="RK45").window_engine == "fortran"
    assert make(engine="scipy", window="auto", method="Radau").window_engine == "scipy"
    assert make(engine="scipy", window=WindowSpec(engine="scipy")).window_engine == "scipy"


def test_impossible_requests_are_refused_with_the_fix():
    with pytest.raises(ValueError, match="use engine='scipy'"):
        make(engine="scipy", window=WindowSpec(engine="fortran"), method="LSODA")
    with pytest.raises(ValueError, match="choose one of compiled, scipy"):
        make(engine="numba")


def test_force_data_is_asked_for_only_where_the_compiled_engine_could_run():
    assert P.wants_force_data("compiled", "auto", False)
    assert not P.wants_force_data("compiled", "auto", True)
    assert not P.wants_force_data("compiled", "BDF", False)
    assert not P.wants_force_data("scipy", "auto", False)


@pytest.mark.parametrize("engine", ["compiled", "scipy"])
def test_a_damped_contact_widens_only_the_auto_window(engine):
    """A dissipative contact term keeps damped_behind(damping) more beads behind an 'auto' window, more for a
    stronger term, none without one; an explicit width or rule is the caller's."""
    from pulsemap.solvers.chain.window import damped_behind

    base = make(engine=engine, window="auto").rule
    weak, strong = (make(engine=engine, window="auto", damping=d).rule for d in (0.05, 1.0))
    assert damped_behind(0.0) == 0 and 0 < damped_behind(0.05) < damped_behind(1.0)
    assert weak.behind == base.behind + damped_behind(0.05) and strong.behind == base.behind + damped_behind(1.0)
    assert (weak.ahead, weak.chunk, weak.threshold) == (base.ahead, base.chunk, base.threshold)
    assert make(engine=engine, window=40, damping=1.0).rule == rule_for_width(40)


def test_the_damped_window_widens_with_the_exponent_the_accuracy_and_a_strong_term():
    """The loaded tail behind a damped pulse reaches further back at larger n, and a strong term's precursor further
    ahead: the plan's 'auto' window keeps more beads behind for n above 3/2 and for a tighter accuracy, none fewer
    below 3/2 than at 3/2, and lowers the ahead threshold only above damping 1."""
    from pulsemap.solvers.chain.window import damped_behind

    behind = [make(window="auto", exponent=n, damping=0.5).rule.behind for n in (1.2, 1.5, 2.0, 2.5, 3.0)]
    assert behind[0] == behind[1] < behind[2] < behind[3] < behind[4]
    assert [damped_behind(0.5, 3.0, a) for a in (1e-6, 1e-8)] == [damped_behind(0.5, 3.0)] * 2
    assert damped_behind(0.5, 3.0, 1e-10) > damped_behind(0.5, 3.0)
    assert damped_behind(2.0) >= 2 * damped_behind(1.0) - 1  # in proportion to a strong term (gamma^0.6 below 1)
    base, weak, strong = (make(window="auto", damping=d).rule.threshold for d in (0.0, 1.0, 3.0))
    assert base == weak and strong == pytest.approx(base / 9.0)
