"""The ahead-of-time chain kernels (solvers/chain/compiled_aot.py): taken whenever a monomial-table
force runs, equal bit for bit to numba's JIT kernels compiled from the same functions, a failed
build falls back to the JIT kernels with one note, concurrent first builds are safe, and a warm CLI
run imports neither numba nor scipy."""

from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import shutil
import subprocess
import sys
import sysconfig
import warnings
from pathlib import Path

import numpy as np
import pytest

import pulsemap
from pulsemap.solvers.chain import compiled, compiled_aot, plan
from pulsemap.solvers.chain.contact_force import ContactTable, kernel_terms
from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.chain.plan import Plan
from pulsemap.solvers.chain.force_table import JitForce, MonomialTable
from pulsemap.solvers.chain.peaks import StopRules
from pulsemap.solvers.chain.window import rule_for_accuracy
from pulsemap.solvers.studies.extent import dns_span
from pulsemap.solvers.studies.scene_chain import make_force

ROOT = Path(__file__).resolve().parents[2]
STATE = ("peaks", "times", "pulse_e", "total_e", "st", "fs", "y")


def _run_both(name: str, method: str, **overrides):
    """The scene's DNS state after the ahead-of-time kernel and after numba's JIT kernel: (kernel, code, run) each."""
    scene = pulsemap.scene(name, **overrides)
    beads, span = dns_span(scene)
    table = make_force(scene, beads).monomials
    args = (Plan("compiled", method, rule_for_accuracy(1e-8), "", ""), Integrator(rtol=1e-8, atol=1e-10),
            StopRules(t_max=1e4, max_steps=10**6))
    out = []
    for aot in (True, False):
        run = compiled.prepare(Chain(beads, scene.exponent, scene.velocity), span, table, *args)
        kernel = compiled.kernel_for(run, aot=aot)[0]
        out.append((kernel, compiled.drive(run, kernel), run))
    return out


@pytest.mark.parametrize("name, method, overrides, form", [
    ("vdp-mu3-v2.3", plan.METHOD, {}, "dense"),
    ("fig8-eps0.1", plan.METHOD, {}, "dense"),
    ("fig8-eps0.1", plan.METHOD, {"perturbation.R": "-mu*v**3"}, "table"),
    ("fig8-eps0.1", "DOP853", {}, "dense"),
    ("fig8-eps0.1", plan.STIFF_METHOD, {"perturbation.params.mu": 10000.0}, "dense"),
])
def test_the_ahead_of_time_kernel_is_taken_and_equals_the_jit_kernel_bit_for_bit(name, method, overrides, form):
    (fast, code_fast, a), (slow, code_slow, b) = _run_both(name, method, **overrides)
    assert compiled_aot.form_of(compiled.kernel_args(a)) == form
    module = sys.modules[compiled_aot.module_name(method, form)]
    assert fast is module.run and Path(module.__file__).parent == compiled_aot.folder()
    assert type(slow).__module__.startswith("numba")  # the comparison ran numba's dispatcher
    assert code_fast == code_slow and int(a.st[4]) > 100  # compiled_layout.NFEV: a real integration
    assert np.isfinite(a.peaks).sum() >= 5
    for field in STATE:
        assert np.array_equal(getattr(a, field), getattr(b, field), equal_nan=True), field


def test_a_run_with_no_force_takes_the_table_kernel_and_equals_the_jit_run():
    first = simulate(Chain(40, 1.5, 1.0), (5, 30), window="auto")
    run = compiled.prepare(Chain(40, 1.5, 1.0), (5, 30), None, Plan("compiled", plan.METHOD, None, "", ""),
                           Integrator(rtol=1e-8, atol=1e-10), StopRules(t_max=1e4, max_steps=10**6))
    assert compiled_aot.form_of(compiled.kernel_args(run)) == "table"
    assert compiled_aot.kernel(plan.METHOD, compiled.kernel_args(run))[0] is not None
    assert first.engine == "compiled" and np.isfinite(first.peaks).all()


def test_form_of_takes_only_what_the_compiled_signatures_accept():
    y = np.zeros(8)
    ints = np.zeros(4, dtype=np.int64)
    base = (y, y, y, ints, y, ints, y, y, y, y, y)
    exps = np.zeros((2, 2), dtype=np.int64)
    bare = (kernel_terms(None, None),)
    assert compiled_aot.form_of(base + (exps, np.zeros((2, 4, 3))) + bare) == "dense"
    assert compiled_aot.form_of(base + (exps, np.zeros((2, 3))) + bare) == "table"
    assert compiled_aot.form_of(base + (exps, np.zeros((3, 2)).T) + bare) is None  # not C-contiguous
    assert compiled_aot.form_of(base + (exps, np.zeros((2, 3), dtype=np.float32)) + bare) is None
    assert compiled_aot.form_of(base + (exps.astype(np.int32), np.zeros((2, 3))) + bare) is None
    jit_force = JitForce((None, None, None), np.zeros((1, 2)))
    assert compiled_aot.form_of(base + jit_force.kernel_args + bare) is None
    assert compiled_aot.kernel(plan.METHOD, base + jit_force.kernel_args + bare) == (None, 0.0, 0.0)
    # a contact law's term or masses take numba's JIT kernels
    masses = kernel_terms(None, np.ones(4))
    dashpot = kernel_terms(ContactTable(np.array([[0.0, 1.0]]), np.ones((1, 3))), None)
    for terms in (masses, dashpot):
        assert compiled_aot.form_of(base + (exps, np.zeros((2, 3)), terms)) is None


def test_the_module_name_follows_kernel_form_and_cpu(monkeypatch):
    name = compiled_aot.module_name("RK45", "dense")
    assert name.startswith("pulsemap_rk45_dense_") and name == compiled_aot.module_name("RK45", "dense")
    assert compiled_aot.module_name("RK45", "table") != name
    monkeypatch.setattr(compiled_aot, "_cpu", lambda: b"another machine")
    compiled_aot._digest.cache_clear()
    try:
        assert compiled_aot.module_name("RK45", "dense") != name
    finally:
        monkeypatch.undo()
        compiled_aot._digest.cache_clear()
    assert compiled_aot.module_name("RK45", "dense") == name


def _damped():
    """A compiled run of a damped 40-bead chain (R = -0.1 v: the dense form)."""
    return compiled.simulate_compiled(Chain(40, 1.5, 1.0), (5, 30), MonomialTable.of([[0, 1]], [[-0.1]]),
                                      Plan("compiled", plan.METHOD, None, "", ""), Integrator(rtol=1e-8, atol=1e-10),
                                      StopRules(t_max=1e4, max_steps=10**6))


FAILING_CC = """#!/bin/sh
case "$*" in *temp.c*) exec gcc "$@";; esac
echo "fake compiler: cannot compile $*" >&2
exit 1
"""


@pytest.mark.parametrize("compiler", ["missing", "failing"])
def test_a_failed_build_says_so_once_and_the_jit_kernel_serves(tmp_path, monkeypatch, capsys, compiler):
    """No C compiler (found missing before any work), or one that passes numba's check and then fails
    (its output kept out of the terminal): one note, the reason on disk, nothing else left, and the
    JIT kernel runs."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # numba.pycc is pending deprecation
        from numba.pycc import platform

    aot = tmp_path / "aot"
    monkeypatch.setattr(compiled_aot, "folder", lambda: aot)
    monkeypatch.setattr(compiled_aot, "_loaded", {})
    cc = tmp_path / "cc"
    if compiler == "failing":
        cc.write_text(FAILING_CC)
        cc.chmod(0o755)
    monkeypatch.setenv("CC", str(cc))  # distutils' C compiler
    platform.external_compiler_works.cache_clear()  # numba checks the compiler once per process
    try:
        got = _damped()
    finally:
        platform.external_compiler_works.cache_clear()
    err = capsys.readouterr().err
    assert err.count("could not be built") == 1 and "JIT kernels serve instead" in err
    assert err.count("ahead of time") == (1 if compiler == "failing" else 0)  # the wait was announced
    assert [p.name for p in aot.iterdir()] == [f"{compiled_aot.module_name(plan.METHOD, 'dense')}.failed"]
    assert ("fake compiler: cannot compile" if compiler == "failing" else "without the compiler") in \
        next(aot.iterdir()).read_text()
    print("stdout still works")
    assert capsys.readouterr().out == "stdout still works\n"

    monkeypatch.setattr(compiled_aot, "_loaded", {})  # a new process: the failure is remembered, not retried
    monkeypatch.setattr(compiled_aot, "build", lambda *a: pytest.fail("rebuilt after a recorded failure"))
    again = _damped()
    assert capsys.readouterr().err == ""
    assert np.array_equal(got.peaks, again.peaks) and np.isfinite(got.peaks).all()
    monkeypatch.undo()
    fast = _damped()  # the machine's ahead-of-time kernel
    assert np.array_equal(fast.peaks, got.peaks) and np.array_equal(fast.peak_times, got.peak_times)


@pytest.mark.slow
def test_a_damaged_module_is_never_loaded_but_built_again(tmp_path, monkeypatch, capsys):
    """A truncated shared library crashes the process that loads it (SIGBUS): the module's sha256, recorded
    when it was built, is checked first; a damaged one is built again with a note and gives the same peaks."""
    aot = tmp_path / "aot"
    monkeypatch.setattr(compiled_aot, "folder", lambda: aot)
    monkeypatch.setattr(compiled_aot, "_loaded", {})
    first = _damped()
    (module,) = [p for p in aot.iterdir() if p.is_file() and not p.name.endswith(".sha256")]  # not the runtime folder
    capsys.readouterr()
    for damage in (lambda b: b[: len(b) // 2], lambda b: b[:4096] + bytes(len(b) - 4096)):
        fresh = module.with_name("damaged")  # a new file renamed over: this process still maps the old one
        fresh.write_bytes(damage(module.read_bytes()))
        os.replace(fresh, module)
        monkeypatch.setattr(compiled_aot, "_loaded", {})  # a new process
        again = _damped()
        err = capsys.readouterr().err
        assert err.count("is damaged (not the file that was built") == 1 and "building it again" in err, err
        assert np.array_equal(again.peaks, first.peaks) and np.array_equal(again.peak_times, first.peak_times)
        assert compiled_aot._intact(module)


CONCURRENT = r"""
import json, sys
from pathlib import Path
from pulsemap.solvers.chain import compiled_aot
compiled_aot.folder = lambda: Path(sys.argv[1])
from pulsemap.solvers.chain.compiled import simulate_compiled
from pulsemap.solvers.chain.dns import Chain, Integrator
from pulsemap.solvers.chain.force_table import MonomialTable
from pulsemap.solvers.chain.peaks import StopRules
from pulsemap.solvers.chain.plan import Plan
res = simulate_compiled(Chain(40, 1.5, 1.0), (5, 30), MonomialTable.of([[0, 1]], [[-0.1]]),
                        Plan("compiled", "RK45", None, "", ""), Integrator(rtol=1e-8, atol=1e-10),
                        StopRules(t_max=1e4, max_steps=10**6))
print(json.dumps([float(p) for p in res.peaks]))
"""


@pytest.mark.process
def test_concurrent_first_builds_install_one_module_atomically(tmp_path):
    aot = tmp_path / "aot"
    procs = [subprocess.Popen([sys.executable, "-c", CONCURRENT, str(aot)], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for _ in range(2)]
    outs = [p.communicate(timeout=600) for p in procs]
    assert all(p.returncode == 0 for p in procs), [e[-2000:] for _, e in outs]
    assert any("ahead of time" in e for _, e in outs)
    peaks = [json.loads(o) for o, _ in outs]
    assert peaks[0] == peaks[1] and len(peaks[0]) > 10
    runtime = compiled_aot.runtime_folder(aot)  # numba's C runtime, compiled once
    assert compiled_aot.runtime_objects(runtime) is not None
    files = sorted(p.name for p in aot.iterdir() if p != runtime)  # one module and its digest, no temporary folder
    assert len(files) == 2 and files[0].startswith(compiled_aot.module_name(plan.METHOD, "dense") + ".")
    assert files[1] == files[0] + ".sha256"


WARM = r"""
import sys
sys.argv = ["pulsemap", "run", "fig8-eps0.1", "--methods", "dns", "--quiet"]
from pulsemap.solvers.cli.main import main
try:
    main()
except SystemExit:
    pass
print(sorted(m for m in ("numba", "scipy", "sympy", "llvmlite") if m in sys.modules), file=sys.stderr)
"""


@pytest.mark.process
def test_a_warm_cli_run_imports_neither_numba_nor_scipy():
    cmd = [sys.executable, "-c", WARM]
    subprocess.run(cmd, capture_output=True, text=True, check=True, env=os.environ.copy())  # warm the caches
    warm = subprocess.run(cmd, capture_output=True, text=True, check=True, env=os.environ.copy())
    assert warm.stderr.strip().splitlines()[-1] == "[]", warm.stderr[-2000:]
    assert "contact" in warm.stdout and "dns" in warm.stdout


def test_the_c_runtime_is_used_only_while_intact(tmp_path):
    """runtime_objects lists the runtime's object files only when each is the file compile_runtime wrote."""
    runtime = tmp_path / "runtime_x"
    assert compiled_aot.runtime_objects(runtime) is None  # none installed
    runtime.mkdir()
    for name, data in (("0_a.o", b"object a"), ("1_b.o", b"object b")):
        (runtime / name).write_bytes(data)
    listed = "".join(f"{hashlib.sha256((runtime / n).read_bytes()).hexdigest()} {n}\n" for n in ("0_a.o", "1_b.o"))
    (runtime / compiled_aot.RUNTIME_LIST).write_text(listed)
    assert compiled_aot.runtime_objects(runtime) == [str(runtime / "0_a.o"), str(runtime / "1_b.o")]
    (runtime / "1_b.o").write_bytes(b"object b, overwritten")
    assert compiled_aot.runtime_objects(runtime) is None
    (runtime / "1_b.o").unlink()
    assert compiled_aot.runtime_objects(runtime) is None


def test_a_later_module_links_the_runtime_compiled_once(tmp_path, monkeypatch):
    """The C runtime the session's first build installed serves a new module's build without a C compile, and
    the module gives the session module's numbers bit for bit."""
    reference = _damped()  # the session's module (its runtime installed beside it)
    runtime = compiled_aot.runtime_folder(compiled_aot.folder())
    if compiled_aot.runtime_objects(runtime) is None:  # a cache whose module predates the shared runtime
        first = tmp_path / "first"
        first.mkdir()
        with monkeypatch.context() as m:
            m.setattr(compiled_aot, "folder", lambda: first)
            m.setattr(compiled_aot, "_loaded", {})
            name = compiled_aot.module_name(plan.METHOD, "dense")
            m.setitem(sys.modules, name, sys.modules.get(name))
            reference = _damped()
        runtime = compiled_aot.runtime_folder(first)
    assert compiled_aot.runtime_objects(runtime) is not None
    aot = tmp_path / "aot"
    aot.mkdir()
    shutil.copytree(runtime, compiled_aot.runtime_folder(aot))
    monkeypatch.setattr(compiled_aot, "folder", lambda: aot)
    monkeypatch.setattr(compiled_aot, "_loaded", {})
    monkeypatch.setattr(compiled_aot, "compile_runtime", lambda *a: pytest.fail("the C runtime compiled again"))
    name = compiled_aot.module_name(plan.METHOD, "dense")
    monkeypatch.setitem(sys.modules, name, sys.modules.get(name))  # loading from tmp_path replaces it: back after
    again = _damped()
    assert compiled_aot._paths(name)[0].parent == aot and compiled_aot._intact(compiled_aot._paths(name)[0])
    assert compiled_aot._loaded[name] is not None  # this build's module ran
    assert np.array_equal(again.peaks, reference.peaks) and np.array_equal(again.peak_times, reference.peak_times)


def test_a_module_built_at_install_is_read_first_and_a_damaged_one_left_with_a_note(tmp_path, monkeypatch, capsys):
    """The package's own modules (setup.py builds them at a non-editable install) serve before the kernel cache and
    are never built again; a damaged one is passed over, silently where the cache holds a good copy, else with a
    note (and the kernel cache's way: here a recorded failed build, so the JIT kernel)."""
    reference = _damped()
    name = compiled_aot.module_name(plan.METHOD, "dense")
    cached = compiled_aot._paths(name)[0]
    installed = tmp_path / "installed"
    installed.mkdir()
    for path in (cached, compiled_aot._digest_path(cached)):
        shutil.copyfile(path, installed / path.name)
    monkeypatch.setattr(compiled_aot, "installed_folder", lambda: installed)
    monkeypatch.setattr(compiled_aot, "build", lambda *a: pytest.fail("built though installed"))
    monkeypatch.setitem(sys.modules, name, sys.modules.get(name))  # loading another copy replaces it: back after
    cache = compiled_aot.folder()
    empty = tmp_path / "empty-cache"
    monkeypatch.setattr(compiled_aot, "folder", lambda: empty)
    monkeypatch.setattr(compiled_aot, "_loaded", {})
    assert compiled_aot.to_build([(plan.METHOD, "dense")]) == []  # nothing for a run to build in the background
    got = _damped()
    assert Path(sys.modules[name].__file__).parent == installed and not empty.exists()
    assert np.array_equal(got.peaks, reference.peaks) and np.array_equal(got.peak_times, reference.peak_times)

    fresh = installed / "damaged"  # a new file renamed over: this process still maps the old one
    fresh.write_bytes(cached.read_bytes()[:4096])
    os.replace(fresh, installed / cached.name)
    monkeypatch.setattr(compiled_aot, "folder", lambda: cache)
    monkeypatch.setattr(compiled_aot, "_loaded", {})
    capsys.readouterr()
    again = _damped()
    assert capsys.readouterr().err == ""  # the cache's good copy serves
    assert Path(sys.modules[name].__file__).parent == cache
    assert np.array_equal(again.peaks, reference.peaks)

    empty.mkdir()
    (empty / f"{name}.failed").write_text("no compiler\n")  # the cache has none and will not build one
    monkeypatch.setattr(compiled_aot, "folder", lambda: empty)
    monkeypatch.setattr(compiled_aot, "_loaded", {})
    assert compiled_aot.to_build([(plan.METHOD, "dense")]) == []
    assert compiled_aot.load(plan.METHOD, "dense") == (None, 0.0, 0.0)
    err = capsys.readouterr().err
    assert err.count("built at install, is damaged") == 1 and "reinstall pulsemap" in err


def _setup_module():
    spec = importlib.util.spec_from_file_location("pulsemap_setup", ROOT / "setup.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)  # not as __main__: setup() is not called
    return module


def _build_folder(tmp_path: Path) -> Path:
    """A build folder as setuptools lays the package out (package-dir: pulsemap is the repository root, its
    symbolic subpackage derive/); solvers/ copied, since the kernels are written into it."""
    package = tmp_path / "lib" / "pulsemap"
    package.mkdir(parents=True)
    shutil.copyfile(ROOT / "__init__.py", package / "__init__.py")
    shutil.copytree(ROOT / "solvers", package / "solvers", ignore=shutil.ignore_patterns("__pycache__", "aot"))
    (package / "symbolic").symlink_to(ROOT / "derive")
    (package / "generated").symlink_to(ROOT / "generated")
    return package.parent


@pytest.mark.process
def test_a_non_editable_install_builds_the_kernels_most_runs_take_into_the_package(tmp_path, monkeypatch):
    """setup.py's build step, on a build folder: INSTALL_KERNELS under the names this process looks for (same
    sources, numba, numpy, Python and CPU), each with its sha256, and they run like the cache's modules."""
    lib = _build_folder(tmp_path)
    _setup_module().build_kernels(lib)
    aot = lib / "pulsemap" / "solvers" / "chain" / "aot"
    suffix = sysconfig.get_config_var("EXT_SUFFIX")
    want = {compiled_aot.module_name(m, f) + suffix for m, f in compiled_aot.INSTALL_KERNELS}
    assert {p.name for p in aot.iterdir()} == want | {n + ".sha256" for n in want}
    assert all(compiled_aot._intact(aot / n) for n in want)
    reference = _damped()
    name = compiled_aot.module_name(plan.METHOD, "dense")
    monkeypatch.setattr(compiled_aot, "installed_folder", lambda: aot)
    monkeypatch.setattr(compiled_aot, "_loaded", {})
    monkeypatch.setitem(sys.modules, name, sys.modules.get(name))
    got = _damped()
    assert Path(sys.modules[name].__file__).parent == aot
    assert np.array_equal(got.peaks, reference.peaks) and np.array_equal(got.peak_times, reference.peak_times)


@pytest.mark.process
def test_an_install_without_a_c_compiler_goes_on_and_leaves_no_kernels(tmp_path, monkeypatch, capsys):
    lib = _build_folder(tmp_path)
    monkeypatch.setenv("CC", str(tmp_path / "no-such-compiler"))
    _setup_module().build_kernels(lib)
    assert not (lib / "pulsemap" / "solvers" / "chain" / "aot").exists()
    assert "the chain kernels were not built at install" in capsys.readouterr().err
