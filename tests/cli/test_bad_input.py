"""The bad-input catalogue: every row is one mistake a user can make.

Three surfaces, one rule: a one-line message that names the problem (asserted on key words),
and no traceback.

* ``CLI``: ``pulsemap.solvers.cli.main.main([...])`` in-process; exit status 2, exactly one line
  ``pulsemap: error: ...`` on stderr (after progress lines a slow machine may print first). A few rows
  also go through a real subprocess (``SUBPROCESS``).
* ``SCENE``: a scene file written to tmp_path; ``load_scene`` raises :class:`SceneError` and
  ``pulsemap run FILE`` exits 2 with one line (both are checked for every row).
* ``API``: a Python call raises a specific ValueError subclass with a one-line message.

Nothing here runs a DNS or a map: every error is found before any computation starts.

Cases that need state or a run live next to the code that catches them: damaged
generated modules in tests/models/test_codeload.py, damaged cache entries and record files in
tests/test_damaged_state.py, wrong argument types in tests/test_api_types.py, scene-file bounds in
tests/data/test_toml_bounds.py, extreme velocities and tolerances in tests/chain/test_scaling.py,
``--json -``/``--csv -`` in tests/cli/test_stdout_document.py, RuntimeWarnings in
tests/test_no_warnings.py, DNS progress in tests/chain/test_dns_progress.py.
"""

from __future__ import annotations

import importlib
import math
import os
import subprocess
import sys
from pathlib import Path
from typing import Callable

import pytest

from conftest import scene_toml, write_scene
from pulsemap.solvers.cli.main import main
from pulsemap.solvers.data.scene import with_overrides

ROOT = Path(__file__).resolve().parents[2]

# --------------------------------------------------------------------------- helpers


def error_line(stderr: str) -> str:
    """The one line 'pulsemap: error: ...' of a refused command, wherever it stands in stderr: before it may
    come what a slow machine prints first (progress lines '[what] ...', the once-per-machine notes that the chain
    kernels are being compiled and how long it took), never a second error or a traceback."""
    lines = stderr.splitlines(keepends=True)
    errors = [line for line in lines if line.startswith("pulsemap: error: ")]
    assert len(errors) == 1 and errors[0].endswith("\n"), stderr
    others = [line for line in lines if line is not errors[0]]
    assert all(line.startswith(("[", "pulsemap: compiling the chain kernels", "pulsemap: compiled the chain kernels"))
               for line in others), stderr
    assert "Traceback" not in stderr
    return errors[0]


def test_the_error_line_is_read_wherever_it_stands():
    """What a loaded machine prints first (a DNS's progress line past 5 s) does not fail a refusal's check;
    a second error or a traceback does."""
    assert error_line("[dns] contact 3/40, t = 2, elapsed 5.1 s\npulsemap: error: bad\n") == "pulsemap: error: bad\n"
    for stderr in ("pulsemap: error: a\npulsemap: error: b\n", "Traceback (most recent call last):\npulsemap: error: a\n",
                   "pulsemap: error: a"):
        with pytest.raises(AssertionError):
            error_line(stderr)


def check_cli(argv: list[str], needles: list[str], capsys) -> str:
    """Run the command in-process; assert exit 2 and one clean line naming the problem."""
    code = main(argv)
    captured = capsys.readouterr()
    assert code == 2, (argv, code, captured.err)
    err = error_line(captured.err)
    assert "Traceback" not in captured.out
    for needle in needles:
        assert needle in err, (needle, err)
    return err


# --------------------------------------------------------------------------- command line

CLI = [
    # expressions: unknown symbols and Python code
    ("unknown symbol, at rest", ["derive", "-mu*w", "--param", "mu=1"], ["R(0,0) = -w", "w: a parameter given no value"]),
    ("unknown symbol, did you mean", ["derive", "-gama*u", "--param", "gamma=1"], ["'gamma'", "typo of 'gama'"]),
    ("__import__", ["derive", "__import__('os').system('true')"], ["'__import__'", "not Python code"]),
    ("attribute access", ["derive", "u.real"], ["attribute access", "not Python code"]),
    ("lambda", ["derive", "lambda x: x"], ["'lambda'", "not allowed"]),
    ("dunder name", ["derive", "u*__class__"], ["'__class__'", "not allowed"]),
    ("subscript", ["derive", "u[0]"], ["'['", "not allowed"]),
    ("very long expression", ["derive", "+".join(["u"] * 1500)], ["too long", "at most 2000"]),
    ("deep nesting", ["derive", "(" * 80 + "u" + ")" * 80], ["nesting too deep"]),
    ("unknown function", ["derive", "-sinn(u)"], ["unknown function 'sinn'", "did you mean 'sin'"]),
    ("not a polynomial", ["derive", "-sin(u)"], ["not a polynomial", "Taylor-expand", "--model energy", "energy-law"]),
    ("R(0,0) != 0", ["derive", "1 - v"], ["R(0,0) = 1", "not zero"]),
    # parameters
    ("parameter given no value, dressed law", ["derive", "-mu*u^2", "--model", "dressed"],
     ["dressed law needs a value for mu", "--param mu=VALUE", "--model energy"]),
    ("parameter given no value, energy law by quadrature", ["derive", "-mu*v*abs(v)", "--model", "energy"],
     ["by quadrature needs a value for mu", "--param mu=VALUE"]),
    ("parameter given no value, singular index", ["derive", "-mu*v", "--A0", "1"], ["without a value for mu", "mu=VALUE"]),
    ("parameter given no value, fold in another", ["derive", "-(u - k*(1 - u^2)*v) - mu*v", "--fold", "mu"],
     ["--fold mu", "without a value for k"]),
    ("parameter given but not used", ["derive", "-mu*v", "--param", "mu=1", "--param", "nu=2"],
     ["'nu'", "not used", "remove it"]),
    ("parameter typo of a used one", ["derive", "-mu*v", "--param", "mu=1", "--param", "muu=2"],
     ["'muu'", "typo", "'mu'"]),
    ("parameter without =", ["derive", "-mu*v", "--param", "mu"], ["NAME=VALUE", "'mu'"]),
    ("parameter not a number", ["derive", "-mu*v", "--param", "mu=abc"], ["'mu'", "unknown symbol 'abc'"]),
    ("parameter python", ["derive", "-mu*v", "--param", "mu=__import__('os')"], ["'__import__'", "not allowed"]),
    ("parameter non-finite", ["derive", "-mu*v", "--param", "mu=1e400"], ["1e400", "not finite"]),
    ("parameter given twice", ["derive", "-mu*v", "--param", "mu=1", "--param", "mu=2"], ["mu", "twice"]),
    ("parameter named eps", ["derive", "-mu*v", "--param", "eps=1"], ["'eps'", "separately"]),
    # numbers: eps, n, A0
    ("eps negative", ["derive", "-mu*v", "--param", "mu=1", "--eps", "-0.1"], ["eps = -0.1", ">= 0", "sign"]),
    ("eps not a number", ["derive", "-mu*v", "--param", "mu=1", "--eps", "small"], ["--eps", "expected a number", "'small'"]),
    ("eps nan", ["derive", "-mu*v", "--param", "mu=1", "--eps", "nan"], ["eps", "not finite"]),
    ("eps 1e400", ["derive", "-mu*v", "--param", "mu=1", "--eps", "1e400"], ["eps", "not finite"]),
    ("n = 1", ["derive", "-mu*v", "--param", "mu=1", "--n", "1"], ["exponent n", "> 1"]),
    ("n = inf", ["profile", "--n", "inf"], ["exponent n", "finite"]),
    ("A0 negative", ["derive", "-mu*v", "--param", "mu=1", "--A0", "-1"], ["A0", "1e-12 <= A0 <= 1e+12"]),
    # derive's numeric options: never a nan/inf law with exit 0
    ("A0 nan", ["derive", "-mu*v", "--param", "mu=1", "--A0", "nan"], ["A0 = nan", "1e-12 <= A0 <= 1e+12"]),
    ("A0 inf", ["derive", "-mu*v", "--param", "mu=1", "--A0", "inf"], ["A0 = inf", "1e-12 <= A0 <= 1e+12"]),
    ("A0 too large", ["derive", "-mu*v+u^3", "--param", "mu=1", "--A0", "1e300"], ["A0 = 1e+300", "outside"]),
    ("A0 underflows", ["derive", "-mu*v+u^3", "--param", "mu=1", "--A0", "1e-300"], ["A0 = 1e-300", "outside"]),
    ("A0 nan, balance", ["derive", "-mu*v", "--param", "mu=1", "--A0", "nan", "--model", "energy"], ["A0 = nan"]),
    ("i0 nan", ["derive", "-mu*v", "--param", "mu=1", "--i0", "nan"], ["i0 = nan", "|i0| <= 1e+12"]),
    ("i0 inf", ["derive", "-mu*v", "--param", "mu=1", "--i0", "inf"], ["i0 = inf"]),
    ("sympy-seconds nan", ["derive", "-mu*v", "--param", "mu=1", "--sympy-seconds", "nan"], ["sympy_seconds = nan"]),
    ("sympy-seconds negative", ["derive", "-mu*v", "--param", "mu=1", "--sympy-seconds", "-1"],
     ["sympy_seconds = -1", "0 <= sympy_seconds <= 3600"]),
    ("n just above 1", ["derive", "-mu*v", "--param", "mu=1", "--n", "1.0000001"],
     ["n = 1.0000001", "1.01 <= n <= 20", "(n - 1)^(-1/2)"]),
    ("profile: n just above 1", ["profile", "--n", "1.0000001"], ["n = 1.0000001", "1.01 <= n <= 20"]),
    ("profile: n too large", ["profile", "--n", "21"], ["n = 21.0", "1.01 <= n <= 20"]),
    ("max-seconds zero", ["derive", "-mu*v", "--param", "mu=1", "--max-seconds", "0"],
     ["max_seconds = 0", "0 < max_seconds <= 86400"]),
    ("max-seconds nan", ["derive", "-mu*v", "--param", "mu=1", "--max-seconds", "nan"], ["max_seconds = nan"]),
    ("max-seconds exceeded", ["derive", "u^12*v^12", "--max-seconds", "0.001", "--quiet"],
     ["derive stopped after", "max_seconds = 0.001", "resumes"]),
    # non-smooth R: the DNS runs it, derive's map and balances refuse it with the reason
    ("Coulomb friction, map", ["derive", "-mu*sign(v)", "--param", "mu=1"],
     ["not a polynomial in u, v", "sign(v) has a kink or a jump at 0", "DNS runs it", "--model energy",
      "run SCENE --methods energy-law"]),
    ("Heaviside, momentum balance", ["derive", "mu*Heaviside(u)*u", "--param", "mu=1", "--model", "momentum"],
     ["not a polynomial", "Heaviside(u)", "DNS runs it"]),
    ("dps not an integer", ["profile", "--dps", "many"], ["--dps", "invalid int value"]),
    # choices
    ("unknown profile", ["profile", "--profile", "spline"], ["unknown profile 'spline'", "exact, pade"]),
    ("unknown variant", ["derive", "-mu*v", "--param", "mu=1", "--variant", "2d"], ["variant '2d'", "paper, corrected, 1d"]),
    ("fold in an unknown parameter", ["derive", "-mu*v", "--param", "mu=1", "--fold", "nu"], ["'nu'"]),
    ("run: unknown method", ["run", "fig8-eps0.1", "--methods", "map,dsn"], ["'dsn'", "did you mean 'dns'"]),
    ("run: unknown profile", ["run", "fig8-eps0.1", "--methods", "dns", "--profile", "spline"], ["profile 'spline'", "exact, pade"]),
    ("run: unknown variant", ["run", "fig8-eps0.1", "--variant", "papper"], ["variant 'papper'", "did you mean 'paper'"]),
    ("run: seed peak negative", ["run", "fig8-eps0.1", "--seed-peak", "-1"], ["seed peak", "> 0"]),
    # files
    ("run: unknown built-in scene", ["run", "fig8-eps03"], ["'fig8-eps03'", "did you mean the built-in scene 'fig8-eps0.3'"]),
    ("run: file does not exist", ["run", "no/such/scene.toml"], ["'no/such/scene.toml' not found"]),
    ("run: a directory", ["run", str(ROOT / "tests")], ["is a directory", ".toml"]),
    ("run: --json into a missing directory", ["run", "fig8-eps0.1", "--json", "/no/such/dir/out.json"],
     ["--json", "/no/such/dir", "does not exist"]),
    # every command that takes a name refuses an unknown one
    ("suite: unknown scene", ["suite", "nosuch"], ["unknown scene 'nosuch'", "pulsemap suite --list"]),
    ("suite: misspelt suite scene", ["suite", "damp-1O"], ["'damp-1O'", "did you mean 'damp-10'"]),
    ("bench: unknown scene", ["bench", "nosuch"], ["'nosuch' not found"]),
    ("table: unknown scene", ["table", "nosuch"], ["'nosuch' not found"]),
    ("table: no workers", ["table", "fig8-eps0.1", "--workers", "0"], ["--workers must be >= 1, got 0"]),
    ("table: workers not a number", ["table", "fig8-eps0.1", "--workers", "two"], ["expected a number of workers", "'two'"]),
    ("generate: unknown scene", ["generate", "nosuch"], ["'nosuch' not found"]),
    ("build-kernels: misspelt kernel", ["build-kernels", "RK45:dens"], ["invalid choice: 'RK45:dens'",
                                                                        "did you mean 'RK45:dense'"]),
    ("ensemble: unknown scene", ["ensemble", "nosuch", "--realisations", "1"], ["'nosuch' not found"]),
    ("bifurcation: unknown scene", ["bifurcation", "nosuch", "--param", "mu", "--range", "0", "1"], ["'nosuch' not found"]),
    ("bifurcation: unknown parameter", ["bifurcation", "vdp-mu3-v2.3", "--param", "nu", "--range", "0", "1"],
     ["'nu' is not a parameter", "mu"]),
    ("bifurcation: unknown profile", ["bifurcation", "vdp-mu3-v2.3", "--param", "mu", "--range", "0", "1",
                                      "--profiles", "spline"], ["unknown profile 'spline'"]),
    ("sweep: unknown scene", ["sweep", "nosuch", "--over", "perturbation.eps=0.1,0.2"], ["'nosuch' not found"]),
    ("sweep: unknown key", ["sweep", "fig8-eps0.1", "--over", "perturbation.epss=0.1,0.2"],
     ["perturbation.epss", "did you mean 'perturbation.eps'"]),
    ("velocity where R's scaled force is too large", ["run", "fig8-eps0.1", "--set", "excitation.velocity=1e-100"],
     ["velocity = 1e-100", "maps R's coefficients", "v0 in ["]),
    ("json and csv both to stdout", ["run", "fig8-eps0.1", "--json", "-", "--csv", "-"], ["both ask for stdout"]),
    # unbounded work: the total degree, and models whose size grows with it, refused before any work
    ("total degree: powers of powers", ["derive", "((u^64)^64)^64"], ["total degree 262144", "more than 64"]),
    ("total degree: a long product", ["derive", "*".join(["u"] * 65)], ["total degree 65", "more than 64"]),
    ("map of degree 64 under --max-seconds", ["derive", "(u+v+1)^64-1", "--max-seconds", "5"],
     ["degree 64", f"{math.comb(64 + 4, 4) - 1} monomials of Eq. 23", "more than the 2000"]),
    ("run: map of degree 30", ["run", "default", "--set", "perturbation.R=(u+v+1)^30-1", "--methods", "map"],
     ["degree 30", f"{math.comb(30 + 4, 4) - 1} monomials", "methods = [\"dns\"]"]),
    ("run: energy balance of degree 30", ["run", "default", "--set", "perturbation.R=(u+v+1)^30-1", "--methods",
                                          "energy-map"], [f"{math.comb(30 + 2, 2) - 1} terms", "more than the 120"]),
    # values that leave float64 or the reals while a model or the DNS runs: one line, never a traceback
    # R is evaluated on perturbed beads only (beads 1..15 pass u = 1 first): the first perturbed bead names it
    ("R singular where the chain goes", ["run", "default", "--set", "perturbation.R=u*exp(1/(u-1))", "--methods", "dns"],
     ["DNS stopped at t = ", "at bead 16 (u = 1.0", "its term exp(1/(u - 1)) is infinite there", "bound R"]),
    ("R singular where the chain goes, scipy engine", ["run", "default", "--set", "perturbation.R=u*exp(1/(u-1))",
                                                       "--methods", "dns", "--set", "dns.engine=scipy"],
     ["DNS stopped at t = ", "at bead 16 (u = 1.0", "its term exp(1/(u - 1)) is infinite there", "bound R"]),
    ("R complex where the chain goes", ["run", "default", "--set", "perturbation.R=sqrt(1-u)-1", "--methods", "dns"],
     ["DNS stopped at t = ", "at bead 16", "its term sqrt(1 - u) is complex there", "finite and real"]),
    ("R complex where the chain goes, implicit scipy", ["run", "default", "--set", "perturbation.R=sqrt(1-u)-1",
                                                        "--methods", "dns", "--set", "dns.engine=scipy",
                                                        "--set", "dns.method=Radau"],
     ["DNS stopped at t = ", "at bead 16", "its term sqrt(1 - u) is complex there"]),
    ("R complex: a fractional power", ["run", "default", "--set", "perturbation.R=(1-u)^(3/2)-1", "--methods", "dns"],
     ["at bead 16", "its term (1 - u)**(3/2) is complex there"]),
    ("R singular on the wave's path, energy map", ["run", "default", "--set", "perturbation.R=u*exp(1/(u-1))",
                                                   "--methods", "energy-map"],
     ["its term 1/(u - 1) is infinite where the wave takes bead 16", "work of R on the wave is not finite"]),
    ("R singular on the wave's path, energy law", ["run", "default", "--set", "perturbation.R=-v/(u-0.5)",
                                                   "--methods", "energy-law"],
     ["its term 1/(u - 1/2) is infinite where the wave takes bead", "work of R on the wave is not finite"]),
    ("R singular on the wave's path, derive --model energy", ["derive", "u*exp(1/(u-1))", "--model", "energy"],
     ["its term 1/(u - 1) is infinite where the wave of amplitude A = ", "meets it", "work of R on the wave is not finite"]),
    ("R singular on the wave's path, derive --model energy with a parameter",
     ["derive", "-mu*v/(u-0.5)", "--param", "mu=1", "--model", "energy"],
     ["its term 1/(u - 1/2) is infinite where the wave of amplitude A = ", "meets it"]),
    ("R singular in the relaxed map's segment runs", ["run", "default", "--set", "perturbation.R=u*exp(1/(u-1))",
                                                       "--methods", "relaxed"],
     ["relaxed: failed: relaxed's segment DNS stopped at t = ", "its term exp(1/(u - 1)) is infinite there"]),
    ("R complex between beads", ["run", "default", "--set", "perturbation.R=(-1)^i*u", "--methods", "energy-law"],
     ["R = (-1)^i*u is complex at contact index", "cos(pi*i)"]),
    ("velocity a 401-digit integer", ["run", "default", "--set", "excitation.velocity=" + "9" * 401],
     ["velocity", "(401 digits) is beyond float64"]),
    ("parameter a 401-digit integer", ["run", "default", "--set", "perturbation.params.mu=" + "9" * 401],
     ["'mu'", "(401 digits) is beyond float64"]),
    ("seed peak 1e300", ["run", "default", "--seed-peak", "1e300", "--methods", "map"],
     ["seed peak 1e+300 is beyond the range 1e-120 <= peak <= 1e+120", "n = 1.5", "give a peak within it"]),
    ("run: --methods ''", ["run", "default", "--methods", ""], ["--methods ''", "names no method"]),
    ("run: nothing ran, with the reason", ["run", "default", "--methods", "dns", "--set", "perturbation.eps=1e300"],
     ["eps = 1e+300, mu = 1 is beyond the range the DNS and the models hold", "times the contact forces",
      "nothing ran: no method produced a peak: DNS: no live primary pulse", "pulse died"]),
    # messages that named a library's words, not the problem
    ("seed peak 1e-300", ["run", "default", "--seed-peak", "1e-300", "--methods", "map"],
     ["seed peak 1e-300 is beyond the range 1e-120 <= peak <= 1e+120"]),
    ("seed peak 5e-324", ["run", "default", "--seed-peak", "5e-324", "--methods", "map"],
     ["seed peak 4.94066e-324 is beyond the range"]),
    ("parameter i^64", ["run", "default", "--set", "perturbation.params.mu=i^64", "--methods", "longwave"],
     ["mu up to", "is beyond the range the DNS and the models hold"]),
    ("sweep --out a /proc file", ["sweep", "default", "--over", "perturbation.eps=0.1,0.2", "--out", "/proc/version",
                                  "--workers", "1", "--quiet"],
     ["cannot write the records file /proc/version", "write elsewhere"]),
    ("eps 1e300, the map", ["run", "default", "--methods", "map", "--set", "perturbation.eps=1e300"],
     ["eps = 1e+300, mu = 1 is beyond the range", "nothing ran"]),
    ("parameter 1e300, map and DNS", ["run", "default", "--methods", "map,dns", "--set", "perturbation.params.mu=1e300"],
     ["mu = 1e+300 is beyond the range", "nothing ran"]),
    ("parameter -1e300, the map", ["run", "default", "--methods", "map", "--set", "perturbation.params.mu=-1e300"],
     ["mu = -1e+300 is beyond the range", "nothing ran"]),
    ("parameter 1e300, long-wave law", ["run", "default", "--methods", "longwave", "--set",
                                        "perturbation.params.mu=1e300"], ["mu = 1e+300 is beyond the range"]),
    ("parameter -1e300, DNS", ["run", "default", "--methods", "dns", "--set", "perturbation.params.mu=-1e300"],
     ["mu = -1e+300 is beyond the range"]),
    ("eps a 401-digit integer", ["run", "default", "--set", "perturbation.eps=" + "9" * 401],
     ["eps = 999999999999... (401 digits) is beyond float64", "(401 characters)"]),
    ("R complex at rest", ["run", "default", "--set", "perturbation.R=(-1)^(i/2)*u", "--methods", "dns"],
     ["R is complex at rest on bead 17", "its term (-1)**(i/2) is complex there"]),
    ("R complex at rest, the map", ["run", "default", "--set", "perturbation.R=(-1)^(i/2)*u", "--methods", "map"],
     ["R is complex at rest on bead 17", "its term (-1)**(i/2) is complex there"]),
    ("60 leading minus signs", ["derive", "-" * 60 + "u"], ["nesting too deep", "signs"]),
    # argparse's own usage errors
    ("no command", [], ["required", "COMMAND"]),
    ("unknown command", ["rnu", "default"], ["invalid choice: 'rnu'", "did you mean 'run'"]),
    ("unknown option", ["run", "default", "--jsn", "x.json"], ["unrecognized arguments: --jsn", "--help"]),
    ("missing argument", ["derive"], ["required", "EXPR"]),
]


@pytest.mark.parametrize("argv, needles", [c[1:] for c in CLI], ids=[c[0] for c in CLI])
def test_cli(argv, needles, capsys):
    err = check_cli(argv, needles, capsys)
    assert len(err) < 600, err  # an echoed value is shortened


SUBPROCESS = [
    ("python in an expression", ["derive", "__import__('os').system('echo PWNED')"], ["'__import__'"]),
    ("unknown option", ["run", "default", "--jsn", "x.json"], ["unrecognized arguments"]),
    ("missing scene file", ["run", "missing.toml"], ["'missing.toml' not found"]),
    ("eps not finite", ["derive", "-mu*v", "--param", "mu=1", "--eps", "inf"], ["eps", "not finite"]),
    ("unknown suite scene", ["suite", "nosuch"], ["unknown scene 'nosuch'"]),
    ("velocity beyond float64", ["run", "fig8-eps0.1", "--set", "excitation.velocity=1e300"], ["outside [1e-150, 1e+150]"]),
    ("rtol below float64", ["run", "fig8-eps0.1", "--set", "dns.rtol=1e-300"], ["rtol >= 2.2e-14"]),
]


@pytest.mark.process
@pytest.mark.parametrize("argv, needles", [c[1:] for c in SUBPROCESS], ids=[c[0] for c in SUBPROCESS])
def test_subprocess(argv, needles, tmp_path):
    """A real process: exit status 2, one line on stderr, nothing executed, no traceback."""
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    out = subprocess.run([sys.executable, "-m", "pulsemap.solvers.cli.main", *argv], capture_output=True, text=True,
                         cwd=tmp_path, env=env, timeout=120)
    assert out.returncode == 2, out
    err = error_line(out.stderr)
    assert "PWNED" not in out.stdout + out.stderr
    for needle in needles:
        assert needle in err, (needle, out.stderr)


# --------------------------------------------------------------------------- scene files

BASE = scene_toml("catalogue", beads=60, contacts=(16, 50), methods=("map", "dns"))


def edit(old: str, new: str) -> str:
    assert old in BASE, old
    return BASE.replace(old, new, 1)


SCENES = [
    ("toml syntax error", edit("eps = 0.1", "eps = = 0.1"), ["TOML syntax error", "line 10"]),
    ("misspelt key", edit("velocity = 1.0", "velocty = 1.0"), ["'velocty'", "did you mean 'velocity'"]),
    ("a name of a million characters", edit('name = "catalogue"', 'name = "' + "n" * 1_000_000 + '"'),
     ["name is 1000000 characters long, more than 1000"]),
    ("misspelt table", edit("[output]", "[ouptut]"), ["[ouptut]", "did you mean [output]"]),
    ("beads zero", edit("beads = 60", "beads = 0"), ["beads = 0", ">= 3"]),
    ("beads negative", edit("beads = 60", "beads = -40"), ["beads = -40", ">= 3"]),
    ("beads a string", edit("beads = 60", 'beads = "60"'), ["beads", "integer", "remove the quotes"]),
    ("beads a list", edit("beads = 60", "beads = [60]"), ["beads", "integer", "array"]),
    ("exponent n <= 1", edit("exponent = 1.5", "exponent = 0.5"), ["exponent", "> 1"]),
    ("velocity zero", edit("velocity = 1.0", "velocity = 0.0"), ["velocity = 0.0", "> 0"]),
    ("velocity negative", edit("velocity = 1.0", "velocity = -1.0"), ["velocity = -1.0", "> 0"]),
    ("velocity a bool", edit("velocity = 1.0", "velocity = true"), ["velocity", "boolean"]),
    ("velocity nan", edit("velocity = 1.0", "velocity = nan"), ["velocity", "not finite"]),
    ("velocity 1e-300", edit("velocity = 1.0", "velocity = 1e-300"), ["velocity = 1e-300", "outside [1e-150, 1e+150]"]),
    ("velocity a 401-digit integer", edit("velocity = 1.0", "velocity = " + "9" * 401),
     ["velocity = 999999999999...", "(401 digits) is beyond float64"]),
    ("velocity 1e300", edit("velocity = 1.0", "velocity = 1e300"), ["velocity = 1e+300", "outside [1e-150, 1e+150]"]),
    ("rtol 1e-300", BASE + "[dns]\nrtol = 1e-300\n", ["rtol = 1e-300", "below what float64 can deliver", "rtol >= 2.2e-14"]),
    ("atol 1e-200", BASE + "[dns]\natol = 1e-200\n", ["atol = 1e-200", "below what the error norm can use", "atol >= 1e-150"]),
    ("eps inf", edit("eps = 0.1", "eps = inf"), ["eps", "not finite"]),
    ("eps 1e400", edit("eps = 0.1", "eps = 1e400"), ["eps", "not finite"]),
    ("eps negative", edit("eps = 0.1", "eps = -0.1"), ["eps = -0.1", ">= 0"]),
    ("eps a string", edit("eps = 0.1", 'eps = "small"'), ["eps", "number", "remove the quotes"]),
    ("contacts outside the chain", edit("contacts = [16, 50]", "contacts = [16, 80]"),
     ["contact 80 is beyond a chain of 60 beads", "raise beads or lower contacts"]),
    ("contacts reversed", edit("contacts = [16, 50]", "contacts = [50, 16]"), ["[50, 16]", "reversed"]),
    ("contacts zero", edit("contacts = [16, 50]", "contacts = [0, 50]"), ["1-based", ">= 1"]),
    ("unknown method", edit('"dns"]', '"DNS"]'), ["'DNS'", "did you mean 'dns'"]),
    ("unknown profile", BASE + '[model]\nprofile = "spline"\n', ["profile 'spline'", "exact, pade"]),
    ("unknown variant", BASE + '[model]\nvariant = "2d"\n', ["variant '2d'", "paper, corrected, 1d"]),
    ("per-bead list of the wrong length", edit("mu = 1.0", "mu = [0.5, 1.0, 1.5]"),
     ["'mu'", "3 per-bead values", "60 beads"]),
    ("per-bead list with a string", edit("mu = 1.0", 'mu = [0.5, "x"]'), ["'mu' element 2", "not a number"]),
    ("random draw without a seed", edit("mu = 1.0", "mu = {uniform = [0, 1]}"), ["'mu'", "seed", "reproducib"]),
    ("random draw with a float seed", edit("mu = 1.0", "mu = {uniform = [0, 1], seed = 1.5}"),
     ["'mu'", "seed must be a non-negative integer"]),
    ("parameter used but not given", edit("mu = 1.0", ""), ["unknown symbol 'mu'", "[perturbation.params]"]),
    ("parameter given but not used", edit("mu = 1.0", "mu = 1.0\ngamma = 2.0"),
     ["'gamma'", "not used", "remove it"]),
    ("python in R", edit('R = "-mu*v"', "R = \"__import__('os').system('echo PWNED')\""), ["'__import__'", "not allowed"]),
    ("attribute access in R", edit('R = "-mu*v"', 'R = "v.__class__"'), ["attribute access"]),
    ("lambda in R", edit('R = "-mu*v"', 'R = "(lambda: v)()"'), ["'lambda'", "not allowed"]),
    ("R a number", edit('R = "-mu*v"', "R = 0.5"), ["R must be a string"]),
    ("empty file", "", ["missing table [excitation]"]),
    # bounds checked before parsing: recursion and memory
    ("arrays nested 500 deep", BASE + "x = " + "[" * 500 + "]" * 500 + "\n", ["nested more than 16 deep"]),
    ("inline tables nested 500 deep", BASE + "x = " + "{a=" * 500 + "1" + "}" * 500 + "\n", ["nested more than 16 deep"]),
    ("dotted key of 20000 parts", BASE + ".".join(["a"] * 20000) + " = 1\n", ["dotted key", "more than 8 parts"]),
    ("table header of 20000 parts", BASE + "[" + ".".join(["a"] * 20000) + "]\n", ["dotted key", "more than 8 parts"]),
    ("key of 5000 characters", BASE + "k" * 5000 + " = 1\n", ["key longer than 200 characters"]),
]


@pytest.mark.parametrize("text, needles", [c[1:] for c in SCENES], ids=[c[0] for c in SCENES])
def test_scene_file(text, needles, tmp_path, capsys):
    from pulsemap.solvers.data.scene import SceneError, load_scene

    path = write_scene(tmp_path, text)
    with pytest.raises(SceneError) as info:
        load_scene(str(path))
    message = str(info.value)
    assert "\n" not in message and str(path) in message, message
    for needle in needles:
        assert needle in message, (needle, message)
    err = check_cli(["run", str(path)], needles, capsys)
    assert "PWNED" not in err


def test_scene_missing_and_directory(tmp_path):
    from pulsemap.solvers.data.scene import SceneError, load_scene

    with pytest.raises(SceneError, match=r"not found.*pulsemap scenes"):
        load_scene(tmp_path / "absent.toml")
    with pytest.raises(SceneError, match="is a directory"):
        load_scene(tmp_path)


# --------------------------------------------------------------------------- Python API


def _scene():
    from pulsemap.solvers.data.scene import load_scene

    return load_scene("fig8-eps0.1")


def _pert(R="-mu*v", eps=0.1, params=None):
    from pulsemap.symbolic.perturbation import make_perturbation

    return make_perturbation(R, eps, {"mu": 1.0} if params is None else params)


def _sympy():
    return importlib.import_module("sympy")


def _sym(name: str):
    return _sympy().Symbol(name)


def _expression_error():
    from pulsemap.symbolic.expression import ExpressionError

    return ExpressionError


def _perturbation_error():
    from pulsemap.symbolic.perturbation import PerturbationError

    return PerturbationError


def _scene_error():
    from pulsemap.solvers.data.scene import SceneError

    return SceneError


def _run_error():
    from pulsemap.solvers.studies.methods import RunError

    return RunError


def _run_choices(methods=None, seed_peak=None, snapshots=()):
    from pulsemap.solvers.api.checks import run_choices

    return run_choices(_scene(), methods, None, None, seed_peak, snapshots)


def _map_error():
    from pulsemap.solvers.models.map_iteration import MapIterationError

    return MapIterationError


def _derive(**kw):
    from pulsemap.symbolic.derivation import derive_all

    return derive_all(_pert(), **kw)


def _iterate(seed_A, seed_contact=15, last=20):
    from pulsemap.solvers.models.codeload import map_module
    from pulsemap.solvers.models.map_iteration import iterate_map

    mod = map_module("-mu*v", ("mu",), 1.5, "exact", "paper")
    return iterate_map(mod, seed_A, seed_contact, last, 0.1, {"mu": 1.0})


def _profile_error():
    from pulsemap.symbolic.profile import ProfileError

    return ProfileError


def _derivation_error():
    from pulsemap.symbolic.derivation import DerivationError

    return DerivationError


def _map_variant_error():
    from pulsemap.symbolic.amplitude_map import MapError

    return MapError


API: list[tuple[str, Callable[[], object], Callable[[], type], list[str]]] = [
    ("parse: __import__", lambda: importlib.import_module("pulsemap.symbolic.expression").parse_expression("__import__('os')"),
     _expression_error, ["'__import__'"]),
    ("parse: lambda", lambda: importlib.import_module("pulsemap.symbolic.expression").parse_expression("(lambda: 1)()"),
     _expression_error, ["'lambda'"]),
    ("parse: not a string", lambda: importlib.import_module("pulsemap.symbolic.expression").parse_expression(b"u"),
     _expression_error, ["must be a string", "bytes"]),
    ("perturbation: eps a string", lambda: _pert(eps="small"), _perturbation_error, ["eps", "unknown symbol 'small'"]),
    ("perturbation: eps negative", lambda: _pert(eps=-0.5), _perturbation_error, ["eps = -0.5", ">= 0"]),
    ("perturbation: eps nan", lambda: _pert(eps=math.nan), _perturbation_error, ["eps", "not finite"]),
    ("perturbation: eps a list", lambda: _pert(eps=[0.1]), _perturbation_error, ["eps", "not a number"]),
    ("perturbation: param a bool", lambda: _pert(params={"mu": True}), _perturbation_error, ["'mu'", "boolean"]),
    ("perturbation: param a dict", lambda: _pert(params={"mu": {"normal": [0, 1], "seed": 1}}),
     _perturbation_error, ["'normal'", "uniform"]),
    ("perturbation: unknown symbol", lambda: _pert("-mu*w"), _perturbation_error, ["unknown symbol 'w'"]),
    ("perturbation: R a list", lambda: _pert(["-mu*v"]), _perturbation_error, ["R must be a string", "list"]),
    # symbolic input bounded the same from every door (expression.bound_size): terms, nodes, degree, float64
    ("perturbation: sympy R of 5000 terms", lambda: _pert(_sympy().Add(*(_sym(f"a{j}") * _sym("v") ** (1 + j % 3)
                                                                                 for j in range(5000)))),
     _perturbation_error, ["R has 5000 terms", "more than 500"]),
    ("perturbation: sympy R of 4200 nodes", lambda: _pert(_sym("v") * _sympy().Mul(*(_sympy().sin(_sym(f"a{j}"))
                                                                                      for j in range(2100)))),
     _perturbation_error, ["R has more than 4000 nodes"]),
    ("perturbation: sympy R of degree 65", lambda: _pert(_sym("u") ** 65), _perturbation_error,
     ["R has total degree 65", "more than 64"]),
    ("perturbation: text R of degree 65", lambda: _pert("u^64*u"), _perturbation_error, ["total degree 65", "more than 64"]),
    ("perturbation: sympy Float 1e400 in R", lambda: _pert(_sympy().Float("1e400") * _sym("u")), _perturbation_error,
     ["R contains the number 1.00000e+400", "beyond float64"]),
    ("perturbation: a 401-digit integer in R", lambda: _pert(_sympy().Integer(10) ** 400 * _sym("u")),
     _perturbation_error, ["(401 digits), beyond float64"]),
    ("perturbation: a number float64 rounds to 0 in R", lambda: _pert(_sympy().Rational(1, 10**400) * _sym("u")),
     _perturbation_error, ["rounds to 0.0"]),
    ("bead values: zero beads", lambda: _pert().bead_values("mu", 0), _perturbation_error, ["beads", "positive"]),
    ("bead values: wrong length", lambda: _pert(params={"mu": [1.0, 2.0]}).bead_values("mu", 5),
     _perturbation_error, ["'mu'", "2 per-bead values", "5 beads"]),
    ("scene override: beads negative", lambda: with_overrides(_scene(), beads=-3), _scene_error, ["beads = -3", ">= 3"]),
    ("scene override: velocity a string", lambda: with_overrides(_scene(), velocity="1"), _scene_error,
     ["velocity", "number"]),
    ("scene override: unknown field", lambda: with_overrides(_scene(), veloctiy=1.0), _scene_error,
     ["'veloctiy'", "did you mean 'velocity'"]),
    ("scene override: eps inf", lambda: with_overrides(_scene(), eps=math.inf), _scene_error, ["eps", "not finite"]),
    ("scene override: parameter not used", lambda: with_overrides(_scene(), R="-v", params={"mu": 1.0}), _scene_error,
     ["'mu'", "not used"]),
    ("run: unknown method", lambda: importlib.import_module("pulsemap").run(_scene(), methods=["mpa"]),
     _run_error, ["'mpa'", "did you mean 'map'"]),
    ("run: seed peak nan", lambda: _run_choices(seed_peak=math.nan), _run_error, ["seed peak", "finite"]),
    ("run: snapshot outside the contacts", lambda: _run_choices(methods=["dns"], snapshots=(5,)), _run_error,
     ["snapshot contact 5", "scene's contacts"]),
    ("run: snapshots without the DNS", lambda: _run_choices(methods=["map"], snapshots=(20,)), _run_error,
     ["snapshots are taken by the DNS"]),
    ("run: unknown profile", lambda: importlib.import_module("pulsemap").run(_scene(), profile="spline"),
     _run_error, ["profile 'spline'"]),
    ("map: seed amplitude negative", lambda: _iterate(-1.0), _map_error, ["seed amplitude", "> 0"]),
    ("map: last contact before seed", lambda: _iterate(1.0, 15, 10), _map_error, ["last contact 10", "seed contact 15"]),
    ("derive: n <= 1", lambda: _derive(n=0.9), _profile_error, ["exponent n", "> 1"]),
    ("derive: unknown variant", lambda: _derive(variant="2d"), _map_variant_error, ["variant '2d'"]),
    ("derive: A0 nan", lambda: _derive(A0_value=math.nan), _derivation_error, ["A0 = nan", "1e-12 <= A0"]),
    ("derive: A0 a string", lambda: _derive(A0_value="1"), _derivation_error, ["A0 must be a number"]),
    ("derive: i0 inf", lambda: _derive(i0=math.inf), _derivation_error, ["i0 = inf"]),
    ("derive: n = 1 + 1e-7", lambda: _derive(n=1.0000001), _profile_error, ["n = 1.0000001", "1.01 <= n"]),
]


def _dns():
    return importlib.import_module("pulsemap.solvers.chain.dns")


def _dns_input_error():
    from pulsemap.solvers.chain.errors import DNSInputError

    return DNSInputError


API += [  # option objects refuse at construction what no run can use, naming the field and its range
    ("Integrator rtol 1e300", lambda: _dns().Integrator(rtol=1e300), _dns_input_error,
     ["rtol = 1e+300", "2.2e-14 <= rtol < 1"]),
    ("Integrator rtol 1", lambda: _dns().Integrator(rtol=1.0), _dns_input_error, ["rtol = 1 ", "rtol < 1"]),
    ("Chain exponent 50", lambda: _dns().Chain(40, 50, 1.0), _profile_error, ["exponent n = 50", "1.01 <= n <= 20"]),
    ("Snapshots span of floats", lambda: _dns().Snapshots(span=(1.5, 2.7)), _dns_input_error,
     ["snapshot span", "integers in 0..", "(1.5, 2.7)"]),
    ("Snapshots span 1e9", lambda: _dns().Snapshots(span=(10**9, 1)), _dns_input_error,
     ["snapshot span", "integers in 0..1000000"]),
    ("Snapshots contacts a string", lambda: _dns().Snapshots(contacts="abc"), _dns_input_error,
     ["snapshot contacts must be a sequence of integers", "'abc'"]),
    ("Snapshots contact a float", lambda: _dns().Snapshots(contacts=[20, 1.5]), _dns_input_error,
     ["snapshot contact 1.5", "integer >= 1"]),
    ("StopRules peak_fraction 2", lambda: _dns().StopRules(peak_fraction=2.0), _dns_input_error,
     ["peak_fraction", "(0, 1)"]),
    ("StopRules t_max nan", lambda: _dns().StopRules(t_max=math.nan), _dns_input_error, ["t_max", "finite number > 0"]),
]


@pytest.mark.parametrize("call, error, needles", [c[1:] for c in API], ids=[c[0] for c in API])
def test_api(call, error, needles):
    cls = error()
    assert issubclass(cls, ValueError) and cls is not ValueError
    with pytest.raises(cls) as info:
        call()
    message = str(info.value)
    assert "\n" not in message, message
    for needle in needles:
        assert needle in message, (needle, message)




def test_catalogue_size():
    """The catalogue's size: >= 30 cases across the three surfaces."""
    total = len(CLI) + len(SUBPROCESS) + len(SCENES) + len(API)
    assert total >= 30 and len(CLI) >= 10 and len(SCENES) >= 10 and len(API) >= 10
    for rows in (CLI, SUBPROCESS, SCENES, API):
        assert len({row[0] for row in rows}) == len(rows)  # every row has its own id


@pytest.mark.parametrize("expr", ["-v", "-mu*v", "-(u - mu*v)"])
def test_an_expression_starting_with_minus_is_not_an_option(expr, capsys):
    """Not an error: R = -v is an expression, not an unknown option -v (no quoting tricks needed)."""
    assert main(["derive", expr, "--param", "mu=1", "--eps", "0.05", "--sympy-seconds", "0"]
                if "mu" in expr else ["derive", expr, "--eps", "0.05", "--sympy-seconds", "0"]) == 0
    out = capsys.readouterr().out
    R = {"-v": "-v", "-mu*v": "-mu*v", "-(u - mu*v)": "mu*v - u"}[expr]  # sympy's printing of R
    assert f"R(u, v) = {R} " in out and "eps = 0.05" in out


def test_override_of_R_keeps_only_the_parameters_it_uses():
    """Not an error: a new R without new params keeps the old values R uses and drops the rest."""
    scene = _scene()
    assert dict(with_overrides(scene, R="-v").perturbation.params) == {}
    assert dict(with_overrides(scene, R="-2*mu*v").perturbation.params) == {"mu": 1.0}


# --------------------------------------------------------------------------- files that are not files


@pytest.mark.parametrize("argv, needles", [
    (["run", "/dev/zero"], ["/dev/zero", "is a character device, not a regular file", ".toml"]),
    (["run", "/dev/urandom"], ["/dev/urandom", "is a character device"]),
    (["run", "FIFO"], ["is a FIFO (named pipe), not a regular file"]),
    (["table", "fig8-eps0.1", "--rows", "/dev/full"], ["/dev/full", "not a regular file"]),
    (["table", "fig8-eps0.1", "--rows", "/dev/full", "--fresh"], ["/dev/full", "not a regular file"]),
    (["table", "fig8-eps0.1", "--rows", "FIFO"], ["is a FIFO (named pipe), not a regular file"]),
    (["sweep", "fig8-eps0.1", "--over", "perturbation.eps=0.1,0.2", "--out", "/dev/zero"],
     ["record file /dev/zero is a character device"]),
], ids=["run /dev/zero", "run /dev/urandom", "run a FIFO", "table --rows /dev/full", "table --rows /dev/full --fresh",
        "table --rows a FIFO", "sweep --out /dev/zero"])
def test_reads_of_devices_and_fifos_end_at_once(argv, needles, tmp_path):
    """Reads are bounded by bytes read and never block: a real process ends within seconds, exit 2."""
    fifo = tmp_path / "scene.toml"
    os.mkfifo(fifo)
    argv = [str(fifo) if a == "FIFO" else a for a in argv]
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
           "PULSEMAP_CACHE_DIR": str(tmp_path / "cache")}
    out = subprocess.run([sys.executable, "-m", "pulsemap.solvers.cli.main", *argv], capture_output=True, text=True,
                         cwd=tmp_path, env=env, timeout=60)
    assert out.returncode == 2, out
    err = error_line(out.stderr)
    for needle in needles:
        assert needle in err, (needle, out.stderr)
    assert os.path.exists("/dev/full") and fifo.exists()
