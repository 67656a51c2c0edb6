"""Site-dependent laws solved as ODEs with the generated modules agree with derive's closed forms."""

import numpy as np
import pytest

from pulsemap.symbolic.balance import derive_balance
from pulsemap.symbolic.derivation import derive_all
from pulsemap.symbolic.perturbation import make_perturbation
from pulsemap.symbolic.site_law import A0, I, I0
from pulsemap.solvers.models.codeload import balance_module, map_module
from pulsemap.solvers.models.site_law_eval import SiteLawError, evaluate_site_law

GRADED = make_perturbation("-k*u", 0.05, {"k": "1 + (i - 16)/50"})


@pytest.mark.parametrize("kind", ["balance", "longwave"])
def test_ode_matches_the_closed_form(kind):
    site = GRADED.site_dependent
    if kind == "balance":
        mod = balance_module(GRADED.text, GRADED.used_parameters, 1.5, "exact", "energy", site)
        law = derive_balance(GRADED, "energy").law
    else:
        mod = map_module(GRADED.text, GRADED.used_parameters, 1.5, "exact", "paper", site)
        law = derive_all(GRADED).longwave
    contacts = np.arange(16, 60)
    run = evaluate_site_law(mod, GRADED, kind, 0.5, 15.0, contacts)
    closed = [float(law.law.xreplace({A0: 0.5, I0: 15.0, I: float(c)})) for c in contacts]
    got = np.array([a for a in run.A if a is not None])
    assert got.size > 10
    closed = np.array(closed[: got.size])
    # generated constants carry 12 digits; near extinction (A -> 0) relative errors grow as 1/A^(Q(1-p))
    strong = closed > 0.1 * 0.5
    assert strong.sum() > 10
    assert np.max(np.abs(got[strong] / closed[strong] - 1)) < 1e-8


def test_extinction_is_reported():
    pert = make_perturbation("-k*u", 0.3, {"k": "1 + (i - 16)/10"})
    mod = balance_module(pert.text, pert.used_parameters, 1.5, "exact", "energy", pert.site_dependent)
    run = evaluate_site_law(mod, pert, "balance", 0.5, 15.0, np.arange(16, 200))
    assert run.ended == "extinction" and run.ended_at is not None
    assert run.A[-1] is None and all(a is not None for a in run.A[:2])


def test_bad_seed():
    mod = balance_module(GRADED.text, GRADED.used_parameters, 1.5, "exact", "energy", GRADED.site_dependent)
    with pytest.raises(SiteLawError, match="initial amplitude"):
        evaluate_site_law(mod, GRADED, "balance", -1.0, 15.0, [16])
    with pytest.raises(SiteLawError, match="law kind"):
        evaluate_site_law(mod, GRADED, "nonsense", 1.0, 15.0, [16])
