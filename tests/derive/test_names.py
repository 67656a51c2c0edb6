"""User names and internal names live apart: renaming a parameter never
changes a number of the derivation, of the generated map/balance/force modules or of the CLI."""

import json
import keyword
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pulsemap.symbolic.derivation import derive_all, to_json, to_latex, to_text
from pulsemap.symbolic.expression import RESERVED, check_parameter_name
from pulsemap.symbolic.perturbation import make_perturbation
from pulsemap.solvers.models.codeload import balance_module, force_module, map_module

#: Names the derivation or a generated module uses itself: profile constants and integrals, the
#: amplitude and law symbols, arguments, locals and globals of the generated code, sympy-ish names.
DANGEROUS = (
    "f1", "f2", "f3", "f4", "f5", "f6", "f7", "g1_0010", "g1_1000", "g2_01", "g2_10", "x", "a_i", "a_prev",
    "a_next", "A", "A0", "A_0", "i0", "i_0", "B", "B_0", "numpy", "K", "Q", "S0", "k", "epsilon", "E1", "K1",
    "V1", "p1", "E_1", "p_1", "base", "safe", "F1", "F2", "J11", "D1", "P", "N_EXPONENT", "SOURCE", "PARAMS",
    "ARGS", "UNIFORM", "LAW_KIND", "VARIANT", "MODEL", "delta_i", "delta_ip1", "v_i", "v_ip1", "k_i", "k_ip1",
    "p_mu", "b0_mu", "force", "force_dx", "stationary", "map_residual", "balance_rate", "float", "print", "sum",
    "E", "I", "pi", "S", "N", "O", "C", "X", "A_i", "A_1", "Symbol",
)

VDP = "-(u - NAME*(1 - u^2)*v)"  # van der Pol: two stationary shocks for NAME = 3 (Eq. 41)
VALUE = 3.0


def _numbers(R: str, name: str, value: float, eps: float = 0.1) -> dict:
    """Every number the derivation gives for R with parameter ``name`` = value."""
    d = derive_all(make_perturbation(R, eps, {name: value}), A0_value=0.8, sympy_seconds=0)
    out = {
        "eq1": [t.value for t in d.amap.power_terms(1)],
        "eq2": [t.value for t in d.amap.power_terms(2)],
        "roots": list(d.stationary.roots) if d.stationary is not None else [],
        "law": list(d.longwave.coefficients) if d.longwave is not None else [],
    }
    if d.longwave is not None and d.longwave.law is not None:
        out["rate"] = [d.longwave.rate()]
        out["singular"] = [d.longwave.singular_index(0.8)[0] or 0.0]
    return out


def _module_numbers(R: str, name: str, value: float) -> dict:
    """Numbers of the generated force, map and energy-balance modules for R at fixed points."""
    x = np.array([-0.3, 0.0, 0.2, 0.7])
    v = np.array([0.5, -0.1, 0.0, 1.3])
    i = np.arange(1.0, 5.0)
    eps = np.full(4, 0.1)
    force = force_module(R, [name])
    amap = map_module(R, [name], 1.5, "exact", "paper")
    bal = balance_module(R, [name], 1.5, "exact", "energy")
    res = amap.map_residual(0.9, 0.8, 0.75, 0.1, value)
    (jac, dprev) = amap.map_jacobian(0.9, 0.8, 0.75, 0.1, value)
    return {
        "force": list(force.force(x, v, i, eps, value)),
        "force_dx": list(force.force_dx(x, v, i, eps, value)),
        "force_dv": list(force.force_dv(x, v, i, eps, value)),
        "residual": list(res),
        "jacobian": [float(j) for row in jac for j in row] + [float(p) for p in dprev],
        "stationary": list(amap.stationary(0.6, value)),
        "dparam": [amap.stationary_dparam(0.6, value)[name]],
        "rhs": [amap.longwave_rhs(0.7, 0.1, value)] if hasattr(amap, "longwave_rhs") else [],
        "balance": [bal.balance_rate(0.6, 0.1, value), bal.balance_step(0.6, 0.1, value)[0]],
    }


def _same(a: dict, b: dict, rel: float = 1e-9) -> None:
    """Equal to ``rel``: a module shipped in generated/ (name ``mu``) was built on another numpy/BLAS
    than a fresh one (any other name), and the exact profile's last digits (accuracy ~1e-10) move with
    it; a name clash changes numbers at O(1)."""
    assert a.keys() == b.keys()
    for key in a:
        assert len(a[key]) == len(b[key]), key
        assert np.allclose(np.asarray(a[key], float), np.asarray(b[key], float), rtol=rel, atol=1e-300), key


@pytest.fixture(scope="module")
def reference():
    R = VDP.replace("NAME", "mu")
    return _numbers(R, "mu", VALUE), _module_numbers(R, "mu", VALUE)


def test_the_reference_has_something_to_lose(reference):
    numbers, _ = reference
    assert len(numbers["roots"]) == 2 and all(v is not None for v in numbers["eq1"])


@pytest.mark.parametrize("name", DANGEROUS)
def test_a_dangerous_name_gives_the_same_numbers(name, reference):
    check_parameter_name(name)  # the parser accepts it, so it must work like any other name
    R = VDP.replace("NAME", name)
    _same(_numbers(R, name, VALUE), reference[0])
    _same(_module_numbers(R, name, VALUE), reference[1])


@pytest.mark.parametrize("name", ["f1", "A", "k", "g1_0010", "epsilon"])
def test_printed_output_shows_the_users_name(name):
    d = derive_all(make_perturbation(f"-{name}*v", 0.1, {name: 1.0}))
    assert f"-{name}*v" in to_text(d).splitlines()[1].replace(" ", "")
    data = json.loads(json.dumps(to_json(d)))
    assert name in data["monomials"][0]["coefficient"]
    assert to_latex(d)


def test_a_site_dependent_parameter_never_meets_a_uniform_one_of_its_bead_name():
    """k per bead gives symbols k_i, k_ip1; a uniform parameter called k_i is another thing."""
    beads = 40
    k = list(np.linspace(0.2, 0.6, beads))
    plain = make_perturbation("-k*u - c*v", 0.1, {"k": k, "c": 0.5})
    clash = make_perturbation("-k*u - k_i*v", 0.1, {"k": k, "k_i": 0.5})
    a, b = derive_all(plain).expansion, derive_all(clash).expansion
    assert len(a.terms) == len(b.terms)
    assert len({s for s in b.g1.free_symbols if s.name == "k_i"}) == 2  # k at bead i and the uniform k_i
    ma = map_module("-k*u - c*v", ["c", "k"], 1.5, "exact", "paper", ("k",))
    mb = map_module("-k*u - k_i*v", ["k", "k_i"], 1.5, "exact", "paper", ("k",))
    assert ma.ARGS == (("c", 0), ("k", 0), ("k", 1)) and mb.ARGS == (("k", 0), ("k", 1), ("k_i", 0))
    from pulsemap.solvers.models.map_iteration import iterate_map

    ra = iterate_map(ma, 0.5, 15, 30, 0.1, {"k": np.array(k), "c": 0.5})
    rb = iterate_map(mb, 0.5, 15, 30, 0.1, {"k": np.array(k), "k_i": 0.5})
    assert len(ra.A) > 5 and np.allclose(ra.A, rb.A, rtol=1e-12)


# ------------------------------------------------------------------------ property
_LEGAL = st.from_regex(r"[A-Za-z][A-Za-z0-9_]{0,6}", fullmatch=True).filter(
    lambda s: s not in RESERVED and not keyword.iskeyword(s) and not keyword.issoftkeyword(s)
)
NAMES = st.one_of(st.sampled_from(DANGEROUS), _LEGAL)
MONOMIALS = [(a, b) for a in range(4) for b in range(3) if 0 < a + b <= 3]


@st.composite
def polynomials(draw):
    """R = sum_j c_j q_j u^a_j v^b_j with parameters q_j among two names, as a text template."""
    count = draw(st.integers(1, 3))
    terms = draw(st.lists(st.sampled_from(MONOMIALS), min_size=count, max_size=count, unique=True))
    parts = []
    for a, b in terms:
        c = draw(st.sampled_from(["1", "2", "1/3", "-1", "-5/7"]))
        q = draw(st.sampled_from(["{0}", "{1}", "{0}*{1}", "1"]))
        parts.append(f"({c})*{q}*u^{a}*v^{b}")
    return " + ".join(parts)


def _used(template: str) -> list[int]:
    return [k for k in (0, 1) if "{%d}" % k in template]


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(polynomials(), st.lists(NAMES, min_size=2, max_size=2, unique=True),
       st.lists(st.floats(0.2, 2.0), min_size=2, max_size=2))
def test_renaming_a_parameter_never_changes_a_number(template, names, values):
    used = _used(template)
    base = ["c0", "c1"]
    R_ref, R_new = template.format(*base), template.format(*names)
    ref = make_perturbation(R_ref, 0.1, {base[k]: values[k] for k in used})
    new = make_perturbation(R_new, 0.1, {names[k]: values[k] for k in used})
    a, b = derive_all(ref, A0_value=0.8, sympy_seconds=0), derive_all(new, A0_value=0.8, sympy_seconds=0)
    _same({"1": [t.value for t in a.amap.power_terms(1)], "2": [t.value for t in a.amap.power_terms(2)]},
          {"1": [t.value for t in b.amap.power_terms(1)], "2": [t.value for t in b.amap.power_terms(2)]})
    assert (a.stationary is None) == (b.stationary is None)
    if a.stationary is not None:
        _same({"roots": a.stationary.roots}, {"roots": b.stationary.roots}, rel=1e-9)
    assert (a.longwave is None) == (b.longwave is None)
    if a.longwave is not None:
        assert a.longwave.kind == b.longwave.kind
        _same({"C": a.longwave.coefficients}, {"C": b.longwave.coefficients})
    # the DNS force module with the user's names as arguments
    x, v = np.array([0.3, -0.2, 1.1]), np.array([-0.4, 0.9, 0.2])
    i, eps = np.arange(1.0, 4.0), np.full(3, 0.1)
    fa = force_module(R_ref, [base[k] for k in used])
    fb = force_module(R_new, [names[k] for k in used])
    va = [values[k] for k in sorted(used, key=lambda k: base[k])]
    vb = [values[k] for k in sorted(used, key=lambda k: names[k])]
    for fn in ("force", "force_dx", "force_dv"):
        assert np.allclose(getattr(fa, fn)(x, v, i, eps, *va), getattr(fb, fn)(x, v, i, eps, *vb), rtol=1e-13, atol=0)


@pytest.mark.process
def test_the_cli_json_is_the_same_for_a_dangerous_name():
    def run(name: str) -> dict:
        out = subprocess.run(
            [sys.executable, "-m", "pulsemap.solvers.cli.main", "derive", f"-{name}*v + {name}*u^3/7",
             "--param", f"{name}=1", "--json", "-"],
            capture_output=True, text=True, timeout=300,
        )
        assert out.returncode == 0, out.stderr
        text = out.stdout
        start = 0 if text.startswith("{") else text.index("\n{") + 1
        return json.JSONDecoder().raw_decode(text[start:])[0]

    ref, new = run("c"), run("f1")
    assert new["stationary"]["roots"] == ref["stationary"]["roots"]
    for eq in ("equation1", "equation2"):
        assert [t["value"] for t in new["map"][eq]] == pytest.approx([t["value"] for t in ref["map"][eq]], rel=1e-13)
    assert new["longwave"]["terms"][0]["value"] == pytest.approx(ref["longwave"]["terms"][0]["value"], rel=1e-13)
    assert "f1" in new["monomials"][0]["coefficient"]
