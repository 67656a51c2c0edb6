"""The chain kernels ahead of time: each kernel of paper Eq. 1's compiled DNS, for a monomial-table force,
built once per machine by numba.pycc into a plain extension module that loads without numba.

    x_i'' = (x_{i-1} - x_i)_+^n - (x_i - x_{i+1})_+^n + sum_m c_m[i] x_i^(a_m) v_i^(b_m)     (paper Eq. 1)

A warm process then neither imports numba (and the scipy.linalg numba imports) nor loads numba's cache:
the module imports in about a millisecond. One module per kernel (RK45, DOP853, Rodas4) and force form
(``dense``: the cubics P_0(u) + v P_1(u); ``table``: the general monomial table), built only when a run
needs it, from the same Python functions as the numba JIT kernels and for this CPU, so both give the
same numbers. Its name holds a hash of the kernels' source files, numba's and numpy's versions, the
Python ABI and the CPU, so an edit, an upgrade or another machine sharing the cache builds a new one.

The modules live in the ``aot`` subfolder of numba's kernel cache (kernel_cache_dir: ``NUMBA_CACHE_DIR``
or the ``numba`` subfolder of the pulsemap cache; a temporary
folder when that cannot be written), built in a private temporary folder and renamed into
place, so concurrent first runs are safe; a non-editable install (setup.py) builds INSTALL_KERNELS into
the package's ``aot`` folder, read first. numba's C runtime, which every module holds, is compiled once
per machine into the ``runtime_<hash>`` folder beside them and linked into each later module. A build
that fails (no C compiler) prints one note, leaves a
``.failed`` file with the reason (not retried: delete it after installing a compiler) and the run
takes numba's JIT kernels (solvers/chain/jit.py), as does a generated numba force (JitForce).
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import os
import sys
import sysconfig
import tempfile
import time
from functools import lru_cache
from pathlib import Path

import numpy as np

from pulsemap.symbolic.cache import cache_root
from pulsemap.solvers.chain import methods

#: The files the kernels are compiled from, whose numba functions call or inline each other (each
#: carries their common cache stamp: tests/chain/test_numba_stamp.py).
SOURCES = ("compiled_ops.py", "compiled_track.py", "compiled_kernel.py", "compiled_stiff.py", "compiled_force.py",
           "compiled_dop853.py", "compiled_layout.py")
#: ``run(y, f, fs, st, cf, ci, peaks, times, pulse_e, total_e, vpeaks, exps, coef, ct)``'s types
#: (compiled.kernel_args), per form of ``coef``; ct in the bare form (contact_force.kernel_terms):
#: a contact law's term or masses take numba's JIT kernels.
SIGNATURE = ("i8(f8[::1], f8[::1], f8[::1], i8[::1], f8[::1], i8[::1], f8[::1], f8[::1], f8[::1], f8[::1], f8[::1],"
             " i8[:, ::1], {}, f8[::1])")
COEF_TYPES = dict(zip(methods.FORMS, ("f8[:, :, ::1]", "f8[:, ::1]")))
FORM_OF_NDIM = {3: "dense", 2: "table"}  # coef (2, 4, L): the dense cubics; (M, L): the table
INTEGER_ARGS = (3, 5, 11)  # st, ci, exps: int64; every other argument float64
#: CPU seconds an ahead-of-time build of one kernel takes on one core, rounded (benchmarks/bench_first_run.py).
BUILD_ESTIMATE_S = 6
#: C flags of numba's runtime support code in a module (the kernel itself is LLVM's: they change no
#: number): unoptimised, no debug information, half the C compile time.
QUICK_CFLAGS = ["-O0", "-g0"]
#: numba's C runtime in every module: its module set-up and helper library (modulemixin.c; pycc adds the memory
#: allocator, nrt.cpp). Compiled once per machine and linked into each module (compile_runtime); numba's typed
#: containers (dict, list, set, its default) are left out: no kernel uses one (a module that did would not
#: import, and its kernel's tests in tests/chain/test_compiled_aot.py would fail)
RUNTIME_SOURCES = ("modulemixin.c",)
RUNTIME = "pulsemap_runtime"  # the runtime's name in its symbols (pycc_init_pulsemap_runtime), one for every module
RUNTIME_LIST = "sha256"  # in the runtime's folder: the sha256 and name of each of its object files
SUBFOLDER = "numba"  # of the pulsemap cache, when numba is given no folder
#: What a non-editable install builds into the package (setup.py), so that no first run waits for a build: the
#: kernel of the explicit method 'auto' takes, for both force forms. The others are built by the first run needing
#: one, or by ``pulsemap build-kernels``.
INSTALL_KERNELS = tuple((methods.auto_pick("explicit"), form) for form in methods.FORMS)
_loaded: dict[str, object] = {}  # module name -> its run (None: not available in this process)


def numba_cache_dir(configured: str, root: Path) -> Path:
    """Where the compiled kernels are cached: ``configured`` (numba's CACHE_DIR as the user set it) if
    not empty, else ``root``/numba (``root``: the pulsemap cache root)."""
    return Path(configured).expanduser() if configured else Path(root) / SUBFOLDER


def kernel_cache_dir(configured: str) -> tuple[Path, Path | None]:
    """The kernel cache for numba's setting ``configured`` (numba_cache_dir under the pulsemap cache root)
    and the folder it could not write (None): when the user set no folder and the pulsemap cache cannot be
    written, one in the system's temporary folder instead, for numba's JIT kernels and these modules alike."""
    path = numba_cache_dir(configured, cache_root())
    if configured or writable(path):
        return path, None
    uid = os.getuid() if hasattr(os, "getuid") else 0
    return Path(tempfile.gettempdir()) / f"pulsemap-numba-{uid}", path


def writable(path: Path) -> bool:
    """Whether ``path`` exists or can be created, and can be written."""
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError:
        return False
    return os.access(path, os.W_OK)


def form_of(args: tuple) -> str | None:
    """The force form of the kernel arguments ``args`` ("dense" or "table"), or None when no
    ahead-of-time kernel takes them (a generated numba force, or an array of another type or layout)."""
    exps, coef, cc = args[-3], args[-2], args[-1]
    if not isinstance(exps, np.ndarray) or not isinstance(coef, np.ndarray) or coef.ndim not in FORM_OF_NDIM:
        return None
    if not isinstance(cc, np.ndarray) or cc.ndim != 1:  # a contact law's term or masses: the JIT kernels
        return None
    for i, a in enumerate(args):
        want = np.int64 if i in INTEGER_ARGS else np.float64
        if not isinstance(a, np.ndarray) or a.dtype != want or not a.flags.c_contiguous:
            return None
    return FORM_OF_NDIM[coef.ndim] if exps.ndim == 2 else None


def _cpu() -> bytes:
    """This machine's CPU as LLVM sees it: /proc/cpuinfo's model and flags where there is one (no
    LLVM load), else llvmlite's host CPU name and features."""
    try:
        lines = Path("/proc/cpuinfo").read_text(errors="replace").splitlines()
        keep = [ln for ln in lines if ln.startswith(("model name", "flags", "Features", "CPU part"))]
        if keep:
            return "\n".join(dict.fromkeys(keep)).encode()
    except OSError:
        pass
    from llvmlite import binding

    return f"{binding.get_host_cpu_name()} {binding.get_host_cpu_features().flatten()}".encode()


def _numba_version() -> bytes:
    """numba's version file, read without importing numba."""
    spec = importlib.util.find_spec("numba")
    folder = Path(spec.origin).parent if spec and spec.origin else None
    try:
        return (folder / "_version.py").read_bytes() if folder else b""
    except OSError:
        return b""


@lru_cache(maxsize=1)  # once per process: reading and hashing takes ~0.3 ms, a tenth of a short run
def _digest() -> str:
    """The hash of what the modules are built from and for (module docstring)."""
    digest = hashlib.sha256()
    here = Path(__file__).parent
    for name in SOURCES:
        digest.update((here / name).read_bytes())
    for part in (_numba_version(), np.__version__.encode(), sys.version.encode(), _cpu()):
        digest.update(part)
    return digest.hexdigest()[:16]


def module_name(method: str, form: str) -> str:
    """The extension module's name for kernel ``method`` and force ``form``."""
    return f"pulsemap_{method.lower()}_{form}_{_digest()}"


def folder() -> Path:
    """The folder of the ahead-of-time modules: ``aot`` in numba's kernel cache (module docstring)."""
    return kernel_cache_dir(os.environ.get("NUMBA_CACHE_DIR", ""))[0] / "aot"


def _import(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.run


def _try_import(name: str, path: Path):
    """``_import``, or None for a file the loader refuses (the JIT kernel serves; a new build replaces it)."""
    try:
        return _import(name, path)
    except ImportError:
        return None


def build(method: str, form: str, name: str, path: Path) -> float:
    """Compile ``run`` of kernel ``method`` for force ``form`` into the extension module ``path``
    (numba.pycc, for this CPU), in a private temporary folder renamed into place, with one line on
    stderr before the wait and one with its seconds after; the seconds it took (numba's import
    included); raises on failure with the compiler's output."""
    started = time.perf_counter()
    import contextlib
    import io
    import shutil
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # numba.pycc is deprecated (still in numba 0.68)
        from numba.pycc import CC
    kernel = importlib.import_module(f"pulsemap.solvers.chain.{methods.kernels()[method]}").run
    work = tempfile.mkdtemp(prefix=f".{name}-", dir=path.parent)
    saved_tmp, log = tempfile.tempdir, io.StringIO()
    out_fd, err_fd = os.dup(1), os.dup(2)
    try:
        tempfile.tempdir = work  # pycc's build folder: inside ours, removed with it
        cc = CC(name)  # raises here when there is no C compiler
        print(f"pulsemap: compiling the chain kernels ({method}, {form} force) ahead of time, once per machine: "
              f"~{BUILD_ESTIMATE_S} s", file=sys.stderr, flush=True)
        cc.output_dir, cc.output_file, cc.target_cpu, cc.verbose = work, path.name, "host", False
        if isinstance(getattr(cc, "_extra_cflags", None), dict):  # numba's C runtime: halves the C compile
            cc._extra_cflags = {"posix": QUICK_CFLAGS}
        cc.export("run", SIGNATURE.format(COEF_TYPES[form]))(kernel.py_func)
        with open(Path(work) / "compiler.log", "w+") as sink, contextlib.redirect_stdout(log), \
                contextlib.redirect_stderr(log), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(sink.fileno(), 1)  # the C compiler's own output (a subprocess) goes to the log
            os.dup2(sink.fileno(), 2)
            try:
                compile_module(cc, runtime_folder(path.parent))
            except Exception as exc:
                os.dup2(out_fd, 1)
                os.dup2(err_fd, 2)
                sink.seek(0)
                said = (log.getvalue() + sink.read()).strip().splitlines()[-3:]
                raise RuntimeError(f"{type(exc).__name__}: {exc}" + "".join(f"\n  {s}" for s in said)) from exc
        built = Path(work) / path.name
        digest_file = Path(work) / _digest_path(path).name
        digest_file.write_text(hashlib.sha256(built.read_bytes()).hexdigest() + "\n", encoding="utf-8")
        os.replace(digest_file, _digest_path(path))  # first the digest: a reader never meets a module unchecked
        os.replace(built, path)
        elapsed = time.perf_counter() - started
    finally:
        os.dup2(out_fd, 1)
        os.dup2(err_fd, 2)
        os.close(out_fd)
        os.close(err_fd)
        tempfile.tempdir = saved_tmp
        shutil.rmtree(work, ignore_errors=True)
    print(f"pulsemap: compiled the chain kernels ({method}, {form} force) in {elapsed:.1f} s", file=sys.stderr,
          flush=True)
    return elapsed


def _low_priority(step, *args):
    """``step(*args)`` with this thread (and the C compiler it starts) at a lower priority where the system
    has one per thread (Linux): numba's runtime is needed only at link time, the kernel's compile goes first."""
    import threading

    try:
        os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), 10)
    except (AttributeError, OSError):
        pass
    return step(*args)


def compile_module(cc, runtime: Path) -> None:
    """``cc.compile()`` linked with the C runtime installed as ``runtime`` (compile_runtime) where it is intact,
    else with one compiled on another core by the C compiler while numba generates the kernel's object code
    (and installed there for the next build); ``cc.compile()`` itself where pycc lacks those steps."""
    from concurrent.futures import ThreadPoolExecutor

    steps = ("_compile_object_files", "_compile_mixins", "_get_extra_ldflags", "_toolchain", "_init_function",
             "_mixin_sources")
    if not all(hasattr(cc, step) for step in steps):
        cc.compile()
        return
    tools = cc._toolchain
    tools.verbose = cc.verbose
    cc._init_function = f"pycc_init_{RUNTIME}"  # the module's import calls the shared runtime's set-up
    build_dir = tempfile.mkdtemp(prefix="pycc-build-")  # in the build's private folder (build)
    ready = runtime_objects(runtime)
    with ThreadPoolExecutor(1) as pool:  # the C compiler is a subprocess: the thread waits without the GIL
        mixins = None if ready else pool.submit(_low_priority, compile_runtime, cc, build_dir, runtime)
        objects, exports = cc._compile_object_files(build_dir)
        objects += ready or mixins.result()
    tools.link_shared(os.path.join(cc.output_dir, cc.output_file), objects, tools.get_python_libraries(),
                      tools.get_python_library_dirs(), export_symbols=exports, extra_ldflags=cc._get_extra_ldflags())


@lru_cache(maxsize=1)
def _runtime_stamp() -> str:
    """The hash of what the C runtime is compiled from and with: numba's and numpy's versions (its sources are
    numba's files, named in RUNTIME_SOURCES), the Python build, the platform and the C flags."""
    parts = (_numba_version(), np.__version__.encode(), sys.version.encode(), sysconfig.get_platform(),
             repr((RUNTIME_SOURCES, QUICK_CFLAGS)))
    return hashlib.sha256(b"\0".join(p if isinstance(p, bytes) else p.encode() for p in parts)).hexdigest()[:16]


def runtime_folder(aot: Path) -> Path:
    """Where the C runtime's object files are kept among the modules of ``aot`` (compile_runtime)."""
    return aot / f"runtime_{_runtime_stamp()}"


def runtime_objects(runtime: Path) -> list[str] | None:
    """The object files of the C runtime installed as ``runtime``, or None when there is none or one of them is
    not the file compile_runtime wrote (its sha256 in the folder's list): then it is compiled again."""
    try:
        entries = [line.split(" ", 1) for line in (runtime / RUNTIME_LIST).read_text(encoding="utf-8").splitlines()]
        intact = bool(entries) and all(hashlib.sha256((runtime / name).read_bytes()).hexdigest() == digest
                                       for digest, name in entries)
    except (OSError, ValueError, UnicodeDecodeError):
        return None
    return [str(runtime / name) for _, name in entries] if intact else None


def compile_runtime(cc, build_dir: str, runtime: Path) -> list[str]:
    """numba's C runtime (RUNTIME_SOURCES, with ``cc``'s C flags) compiled into object files in ``build_dir``,
    the same names in every module (RUNTIME); a copy is installed as ``runtime`` for every later build, in a
    private folder renamed into place (when another process got there first, its copy stays)."""
    import shutil

    shared = type(cc)(RUNTIME)
    shared._mixin_sources, shared._extra_cflags = list(RUNTIME_SOURCES), cc._extra_cflags
    shared._toolchain.verbose = cc.verbose
    objects = shared._compile_mixins(build_dir)
    if runtime.exists() and runtime_objects(runtime) is None:  # a damaged copy (not one installed meanwhile)
        shutil.rmtree(runtime, ignore_errors=True)
    staging = Path(tempfile.mkdtemp(prefix=".runtime-", dir=runtime.parent))
    try:
        staging.chmod(0o755)  # as readable as the modules beside it (mkdtemp's folder is its owner's alone)
        names = [f"{i}_{Path(obj).name}" for i, obj in enumerate(objects)]
        for obj, name in zip(objects, names):
            shutil.copyfile(obj, staging / name)
        listed = "".join(f"{hashlib.sha256((staging / n).read_bytes()).hexdigest()} {n}\n" for n in names)
        (staging / RUNTIME_LIST).write_text(listed, encoding="utf-8")
        os.replace(staging, runtime)
    except OSError:  # another build installed it meanwhile (or the folder cannot be written): this one links its own
        pass
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return objects


def kernel(method: str, args: tuple):
    """The ahead-of-time ``run`` of kernel ``method`` for the arguments ``args``, the seconds it took
    to build or load it and, of those, to build it, or (None, 0.0, 0.0) when there is none (generated
    numba force, build failed, cache not writable): the caller then takes numba's JIT kernel. Builds
    the module at its first use on this machine (build)."""
    form = form_of(args)
    if form is None or method not in methods.kernels():
        return None, 0.0, 0.0
    return load(method, form)


def _digest_path(path: Path) -> Path:
    """The file holding the sha256 of module ``path``, written by build."""
    return path.with_name(path.name + ".sha256")


def _intact(path: Path) -> bool:
    """Whether module ``path`` is the file build wrote (its sha256 recorded next to it): a truncated or
    overwritten shared library can crash the process when loaded (SIGBUS), so it is checked first."""
    try:
        recorded = _digest_path(path).read_text(encoding="utf-8").strip()
        return hashlib.sha256(path.read_bytes()).hexdigest() == recorded
    except (OSError, UnicodeDecodeError):
        return False


def _paths(name: str) -> tuple[Path, Path]:
    """Module ``name``'s file and its ``.failed`` file (the folder is looked up: once a process has the
    module, callers ask ``_loaded`` first)."""
    path = folder() / f"{name}{sysconfig.get_config_var('EXT_SUFFIX') or '.so'}"
    return path, path.with_name(f"{name}.failed")


def installed_folder() -> Path:
    """Where a non-editable install puts the modules it built (setup.py: INSTALL_KERNELS), in the package."""
    return Path(__file__).with_name("aot")


def load(method: str, form: str):
    """kernel's answer for kernel ``method`` and force ``form``: the module loaded, built first if this
    machine has none (a failed build: one note, the ``.failed`` file, and (None, 0.0, 0.0))."""
    name = module_name(method, form)
    if name in _loaded:
        return _loaded[name], 0.0, 0.0
    start = time.perf_counter()
    path, failed = _paths(name)
    installed = installed_folder() / path.name
    run, built = None, 0.0
    if _intact(installed):  # built at install (setup.py) for these sources, versions and CPU
        run = _try_import(name, installed)
    elif installed.exists() and not _intact(path):  # once the cache holds a good copy, that one serves silently
        print(f"pulsemap: note: the ahead-of-time kernel {installed}, built at install, is damaged (its sha256 "
              "differs or is missing): the kernel cache serves; reinstall pulsemap to replace it", file=sys.stderr,
              flush=True)
    if run is None and path.exists() and not _intact(path):
        print(f"pulsemap: note: the ahead-of-time kernel {path} is damaged (not the file that was built: its "
              "sha256 differs or is missing): building it again", file=sys.stderr, flush=True)
    elif run is None and path.exists():
        run = _try_import(name, path)
    if run is None and not failed.exists() and writable(path.parent):
        try:
            built = build(method, form, name, path)
            run = _import(name, path)
        except Exception as exc:  # noqa: BLE001 - any build failure: the JIT kernels serve
            why = str(exc).strip() or type(exc).__name__
            short = why.splitlines()[0].split(". ")[0]
            print(f"pulsemap: note: the ahead-of-time kernel could not be built ({short}); numba's JIT kernels "
                  f"serve instead (slower start). Reason in {failed}: delete it to try again.",
                  file=sys.stderr, flush=True)
            try:
                failed.write_text(why + "\n", encoding="utf-8")
            except OSError:
                pass
    _loaded[name] = run
    return (run, time.perf_counter() - start, built) if run is not None else (None, 0.0, 0.0)


def to_build(kernels) -> list[tuple[str, str]]:
    """Those of ``kernels`` ((method, form) pairs) that this machine has no module of yet and could build."""
    todo = []
    for method, form in dict.fromkeys(kernels):
        if method in methods.kernels() and form in COEF_TYPES and module_name(method, form) not in _loaded:
            path, failed = _paths(module_name(method, form))
            if _intact(installed_folder() / path.name):
                continue
            if not path.exists() and not failed.exists() and writable(path.parent):
                todo.append((method, form))
    return todo


def build_in_background(kernels):
    """Start building the modules of ``kernels`` ((method, form) pairs) that this machine lacks in a child
    process, on another core while this one works on; returns the child (``wait()`` before the first run
    that needs them: a run that finds no module builds its own) or None when there is nothing to build."""
    import subprocess

    todo = to_build(kernels)
    if not todo or not sys.executable:
        return None
    try:
        return subprocess.Popen([sys.executable, "-m", __name__, *(f"{m}:{f}" for m, f in todo)],
                                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL)
    except OSError:  # no process to be had (an embedded interpreter, a process limit): the run builds its own
        return None


if __name__ == "__main__":  # build_in_background's child: METHOD:FORM ... (none: INSTALL_KERNELS, setup.py's)
    try:
        for item in sys.argv[1:] or [f"{m}:{f}" for m, f in INSTALL_KERNELS]:
            load(*item.split(":"))
    except KeyboardInterrupt:  # Ctrl-C reaches the command too, which says so: the child ends quietly
        sys.exit(130)
