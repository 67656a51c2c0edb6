"""Load the generated modules (generated/ or the cache) a scene needs, by their source hash.

Looking a module up never imports sympy; only when the module is missing is ``derive`` called to
write it (opty's habit: generated code carries the hash of its source, so stale code is never
used and never silently rebuilt). A balance model the derivation found undefined for R is kept
too, as its reason, so asking again refuses it without sympy.
"""

from __future__ import annotations

import importlib.util
import shutil
import sys
from pathlib import Path
from types import ModuleType

from pulsemap.symbolic import __version__
from pulsemap.symbolic.errors import PulsemapError
from pulsemap.symbolic.cache import cache_dir, load, store
from pulsemap.symbolic.sources import (BALANCE_MODELS, PROFILE_KINDS, VARIANTS, BalanceSource, ForceSource, GeneratedCodeError,
                            JitForceSource, MapSource, module_name, source_from_dict, verify_generated)

PACKAGE_DIR = Path(__file__).resolve().parents[2] / "generated"
#: Cache namespace of the refusals: a generated module's name -> why its model is undefined for R.
REFUSALS = "refusals"


class GeneratedModuleError(PulsemapError):
    """A generated module that fails its checks where it cannot be regenerated (the package's generated/)."""


def _dirs() -> list[Path]:
    return [PACKAGE_DIR, cache_dir() / "generated"]


def _verified_text(path: Path) -> str:
    """The text of generated file ``path`` if it is whole and ours: UTF-8, both hashes right, and
    named by its own source (a valid module copied under another name is refused too)."""
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as exc:
        raise GeneratedCodeError(f"not UTF-8 text (byte {exc.start}), so not a generated module") from None
    try:
        source = source_from_dict(verify_generated(text))
    except GeneratedCodeError:
        raise
    except (ValueError, TypeError, KeyError, AttributeError) as exc:  # a header that parses as JSON but is not a source
        raise GeneratedCodeError(f"its header names no valid source ({type(exc).__name__})") from None
    if module_name(source) != path.stem:
        raise GeneratedCodeError(f"it holds the code of {module_name(source)}, not of {path.stem}")
    return text


def _module_key(name: str) -> str:
    """The import name a generated module ``name`` is executed under."""
    return f"pulsemap_generated_{name}"


def _exec(path: Path) -> ModuleType:
    """The generated file ``path`` (checked by the caller) as a module, executed once per process: its name holds
    the hash of its source, so a later call (each segment run of a relaxed table) takes the one in sys.modules,
    where numba's cache of a jitforce module's functions also finds it."""
    before = sys.modules.get(_module_key(path.stem))
    if before is not None and getattr(before, "__file__", None) == str(path):
        return before
    spec = importlib.util.spec_from_file_location(_module_key(path.stem), path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        if before is None:
            del sys.modules[spec.name]
        else:
            sys.modules[spec.name] = before
        raise
    return module


def _load_path(path: Path) -> ModuleType:
    """Load a generated file after its checks; a failed check is a GeneratedModuleError naming the file."""
    try:
        _verified_text(path)
    except GeneratedCodeError as exc:
        raise GeneratedModuleError(f"generated module {path} is damaged: {_reason(exc)}") from None
    return _exec(path)


def _reason(exc: GeneratedCodeError) -> str:
    return str(exc).split(":")[0]  # the finding, without the fix (the caller gives its own)


def load_by_name(name: str) -> ModuleType:
    """Load generated module ``name`` (e.g. ``map_0123abcd...``) from generated/ or the cache."""
    for folder in _dirs():
        path = folder / f"{name}.py"
        if path.is_file():
            return _load_path(path)
    raise FileNotFoundError(f"no generated module {name}: run the scene once to generate it")


def _ensure(source) -> ModuleType:
    """The module of ``source``: the package's copy (refused if damaged), else the cache's (regenerated,
    with a one-line note on stderr, if damaged), else generated now."""
    name = module_name(source)
    cached = cache_dir() / "generated" / f"{name}.py"
    shipped = PACKAGE_DIR / f"{name}.py"
    if shipped.is_file():
        try:
            _verified_text(shipped)
        except GeneratedCodeError as exc:
            raise GeneratedModuleError(
                f"generated module {shipped} shipped with pulsemap is damaged ({_reason(exc)}): reinstall "
                f"pulsemap (a maintainer's checkout: pulsemap generate --into {PACKAGE_DIR})") from None
        return _exec(shipped)
    if cached.is_file():
        try:
            _verified_text(cached)
            return _exec(cached)
        except GeneratedCodeError as exc:
            print(f"pulsemap: note: cached module {cached} was damaged ({_reason(exc)}): regenerating it",
                  file=sys.stderr, flush=True)
    refused = _refusal(name)
    if refused is not None:
        from pulsemap.symbolic.balance_constants import BalanceError  # mpmath, not sympy

        raise BalanceError(refused)
    from pulsemap.symbolic import codegen  # only now: the code is missing or damaged and must be generated
    from pulsemap.symbolic.balance_constants import BalanceError

    try:
        path = codegen.write(source)
    except BalanceError as exc:  # undefined for this source, whenever asked: kept with its reason
        try:
            store(REFUSALS, _refusal_key(name), {"reason": str(exc)})
        except OSError:  # no usable cache: the next run derives it again
            pass
        raise
    if path == cached:
        return _load_path(path)
    try:  # its place in the cache is taken: built in a private temporary folder, removed once loaded
        return _load_path(path)
    finally:
        shutil.rmtree(path.parent, ignore_errors=True)


def _refusal_key(name: str) -> str:
    return f"refusal {__version__} {name}"


def _refusal(name: str) -> str | None:
    """Why the model of generated module ``name`` was found undefined for its R, if it was."""
    try:
        value = load(REFUSALS, _refusal_key(name), _check_refusal, quiet=True)
    except OSError:
        return None
    return None if value is None else value["reason"]


def _check_refusal(value) -> str | None:
    ok = isinstance(value, dict) and isinstance(value.get("reason"), str) and value["reason"]
    return None if ok else "not a refusal"


def _check_profile(profile: str) -> None:
    if profile not in PROFILE_KINDS:
        raise PulsemapError(f"unknown profile {profile!r}: choose one of {', '.join(PROFILE_KINDS)}")


def map_module(R_text: str, params, n: float, profile: str = "exact", variant: str = "paper",
               site_dependent=()) -> ModuleType:
    """The generated map module (Eq. 23, one variant) for this source, generating it if missing."""
    if variant not in VARIANTS:
        raise PulsemapError(f"unknown map variant {variant!r}: choose one of {', '.join(VARIANTS)}")
    _check_profile(profile)
    return _ensure(MapSource.of(R_text, params, n, profile, variant, site_dependent))


def force_module(R_text: str, params) -> ModuleType:
    """The generated on-site force module for R, generating it if missing."""
    return _ensure(ForceSource.of(R_text, params))


def jit_force_module(R_text: str, params) -> ModuleType:
    """The generated numba force module for R (the compiled DNS's non-polynomial force, in the cache),
    generating it if missing; executed once per process (``_exec``; numba compiles its functions the first time
    and loads them from its cache afterwards). CodegenError (a RuntimeError) when R has no such form."""
    from pulsemap.solvers.chain import jit  # numba's cache folder set before the module's functions exist

    source = JitForceSource.of(R_text, params)
    loaded = sys.modules.get(_module_key(module_name(source)))
    if loaded is not None:  # executed in this process already (_exec): numba's folder is set
        return loaded
    jit.configure()
    return _ensure(source)


def balance_module(R_text: str, params, n: float, profile: str = "exact", model: str = "energy",
                   site_dependent=()) -> ModuleType:
    """The generated energy- or momentum-balance module for this source, generating it if missing.

    Raises pulsemap.symbolic.balance.BalanceError (a ValueError) when the model is undefined for R.
    """
    if model not in BALANCE_MODELS:
        raise PulsemapError(f"unknown balance model {model!r}: choose one of {', '.join(BALANCE_MODELS)}")
    _check_profile(profile)
    return _ensure(BalanceSource.of(R_text, params, n, profile, model, site_dependent))
