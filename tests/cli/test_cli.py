"""The pulsemap command line: outputs and one-line errors with exit status 2."""

import json
import os
import subprocess
import sys

import pytest

from pulsemap.solvers.cli.main import main


def test_profile_json(tmp_path, capsys):
    out = tmp_path / "p.json"
    assert main(["profile", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["S0"] > 1 and data["pade"]["fit_error"] < 1e-3
    assert abs(data["f1"] - 2 * data["f2"] + data["f3"]) < 1e-10
    assert "S(0)" in capsys.readouterr().out


def test_derive_json_has_the_contract_keys(tmp_path):
    out = tmp_path / "d.json"
    assert main(["derive", "-(u - mu*(1-u^2)*v)", "--param", "mu=3", "--fold", "mu", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    for key in ("S0", "f1", "f2", "f3", "f4", "f5", "f6", "monomials", "longwave", "stationary"):
        assert key in data
    assert {"param", "value", "A", "peak"} <= set(data["stationary"]["fold"])
    assert len(data["stationary"]["roots"]) == 2


def test_derive_keeps_a_parameter_without_value_symbolic_as_the_api_does(tmp_path, capsys):
    """``pulsemap derive "-mu*v"``: the law with mu free, the same law as pulsemap.derive's; mu = 2
    substituted in it is the numeric law of ``--param mu=2``. A fold solves for its own parameter, so
    ``--fold mu`` needs no value of mu and finds the fold of ``--param mu=3 --fold mu``."""
    import sympy

    import pulsemap

    free, fixed = tmp_path / "free.json", tmp_path / "fixed.json"
    assert main(["derive", "-mu*v", "--quiet", "--json", str(free)]) == 0
    out = capsys.readouterr().out
    assert "roots of Eq. 41 cannot be computed without a value for mu" in out and "*mu*" in out
    assert main(["derive", "-mu*v", "--param", "mu=2", "--quiet", "--json", str(fixed)]) == 0
    free, fixed = json.loads(free.read_text()), json.loads(fixed.read_text())
    assert free["free_parameters"] == ["mu"] and "free_parameters" not in fixed
    law = sympy.sympify(free["longwave"]["law_numeric"])
    assert law == sympy.sympify(str(pulsemap.derive("-mu*v").details.longwave.numeric_law()))
    point = {"A_0": 0.7, "i_0": 3, "i": 17}
    a = float(law.subs({"mu": 2, **point}))
    b = float(sympy.sympify(fixed["longwave"]["law_numeric"]).subs(point))
    assert a == pytest.approx(b, rel=1e-14) and abs(a - 0.7) > 1e-3
    vdp = "-(u - mu*(1 - u^2)*v)"
    folds = []
    for extra in ([], ["--param", "mu=3"]):
        path = tmp_path / f"fold{len(extra)}.json"
        assert main(["derive", vdp, "--fold", "mu", "--quiet", "--json", str(path), *extra]) == 0
        folds.append(json.loads(path.read_text())["stationary"]["fold"])
    assert folds[0] == folds[1] and folds[0]["param"] == "mu" and folds[0]["value"] > 0


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["profile", "--n", "1"], "exponent n"),
        (["profile", "--profile", "spline"], "unknown profile"),
        (["derive", "-mu*w", "--param", "mu=1"], "R(0,0) = -w"),
        (["derive", "__import__('os').system('true')"], "__import__"),
        (["derive", "sinn(u)"], "sinn"),
        (["derive", "-mu*u^2", "--model", "dressed"], "mu"),
        (["derive", "sin(u)"], "not a polynomial"),
        (["derive", "-mu*v", "--param", "mu=1", "--fold", "nu"], "nu"),
        (["derive", "-mu*v", "--param", "mu=1", "--variant", "2d"], "variant"),
        (["run", "no-such-scene"], "no-such-scene"),
        (["run", "fig8-eps0.1", "--methods", "map,dsn"], "dsn"),
    ],
)
def test_bad_input_is_one_line_exit_2(argv, fragment, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("pulsemap: error:")
    assert fragment in err
    assert "Traceback" not in err


def test_console_script_module_runs():
    out = subprocess.run([sys.executable, "-m", "pulsemap.solvers.cli.main", "scenes"], capture_output=True, text=True)
    assert out.returncode == 0 and "fig8-eps0.3" in out.stdout


def test_generate_writes_the_scene_modules_and_is_the_door_to_the_dressed_tables(tmp_path, capsys, monkeypatch):
    """`pulsemap generate --into DIR` writes the shipped modules of a scene byte for byte; --dressed-tables
    recomputes both shipped tables of the dressed law (here replaced by recorders: they take minutes)."""
    from pulsemap.symbolic.codegen import PACKAGE_DIR
    from pulsemap.solvers.models import dressed_expansion as derived
    from pulsemap.solvers.studies import dressed_calibration as calibrated

    calls = []
    for module in (derived, calibrated):
        monkeypatch.setattr(module, "write_shipped", lambda module=module: calls.append(module) or module.SHIPPED)
    assert main(["generate", "fig8-eps0.1", "--into", str(tmp_path)]) == 0 and calls == []
    written = sorted(tmp_path.glob("*.py"))
    assert len(written) == 4  # force, map, energy and momentum balance of R = -mu*v
    assert all(p.read_bytes() == (PACKAGE_DIR / p.name).read_bytes() for p in written)
    assert main(["generate", "fig8-eps0.1", "--into", str(tmp_path), "--dressed-tables"]) == 0
    assert calls == [derived, calibrated]
    out = capsys.readouterr().out
    assert f"{derived.SHIPPED}  <- the dressed law's derived coefficients" in out
    assert f"{calibrated.SHIPPED}  <- the dressed law's calibrated coefficients" in out


def test_build_kernels_builds_once_and_a_run_then_only_loads(tmp_path, monkeypatch, capsys):
    """``pulsemap build-kernels KERNEL`` builds the module a run would build at its first use; asked again it
    keeps it, and a run takes it without building."""
    from pulsemap.solvers.chain import compiled_aot
    from pulsemap.solvers.studies.run import run_scene
    from pulsemap.solvers.data.scene import load_scene

    monkeypatch.setattr(compiled_aot, "folder", lambda: tmp_path / "aot")
    monkeypatch.setattr(compiled_aot, "_loaded", {})
    name = compiled_aot.module_name("RK45", "dense")
    monkeypatch.setitem(sys.modules, name, sys.modules.get(name))  # loading from tmp_path replaces it: back after
    assert main(["build-kernels", "RK45:dense"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("RK45:dense") and " built in " in out[0] and str(tmp_path / "aot") in out[-1]
    assert compiled_aot._intact(compiled_aot._paths(name)[0])
    monkeypatch.setattr(compiled_aot, "_loaded", {})  # a new process
    assert main(["build-kernels", "RK45:dense"]) == 0
    assert capsys.readouterr().out.splitlines()[0].split() == ["RK45:dense", "already", "built"]
    monkeypatch.setattr(compiled_aot, "_loaded", {})
    monkeypatch.setattr(compiled_aot, "build", lambda *a: pytest.fail("a run built a kernel built ahead"))
    timings = run_scene(load_scene("fig8-eps0.1"), methods=["dns"])["timings_s"]
    assert "dns_build" not in timings and compiled_aot._loaded[name] is not None


@pytest.mark.process
def test_building_the_parser_loads_no_numpy():
    """Every command's parser (build-kernels' choices too) is built from the tables alone (a fresh interpreter)."""
    code = "import sys; from pulsemap.solvers.cli.main import build_parser; build_parser(); print('numpy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


@pytest.mark.parametrize("given", [{}, {"OPENBLAS_NUM_THREADS": "4"}, {"OMP_NUM_THREADS": "3"}, {"MKL_NUM_THREADS": "2"}])
def test_a_command_runs_one_blas_thread_unless_the_user_chose(given):
    from pulsemap.solvers.cli.main import one_blas_thread

    environ = {"PATH": "/bin", **given}
    one_blas_thread(environ)
    assert environ == ({"PATH": "/bin", "OPENBLAS_NUM_THREADS": "1"} if not given else {"PATH": "/bin", **given})


@pytest.mark.process
def test_a_command_sets_one_blas_thread_before_numpy_loads_openblas():
    """The console script's process (and the workers it starts) gets OPENBLAS_NUM_THREADS=1 before numpy loads;
    main() called from Python with its arguments leaves the caller's environment alone."""
    from pulsemap.solvers.cli.main import BLAS_THREADS

    code = ("import os, sys; from pulsemap.solvers.cli import main as m; seen = []\n"
            "m.build_parser = lambda f=m.build_parser: (seen.append(('numpy' in sys.modules,"
            " os.environ.get('OPENBLAS_NUM_THREADS'))), f())[1]\n"
            "sys.argv = ['pulsemap', 'scenes']; m.main({}); print(seen)")
    env = {k: v for k, v in os.environ.items() if k not in BLAS_THREADS}
    seen = [subprocess.run([sys.executable, "-c", code.format(args)], env=env, capture_output=True, text=True,
                           check=True).stdout.strip().splitlines()[-1] for args in ("", "['scenes']")]
    assert seen == ["[(False, '1')]", "[(False, None)]"], seen
