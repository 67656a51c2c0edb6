"""Load the generated modules (generated/ or the cache) a scene needs, by their source hash.

Looking a module up never imports sympy; only when the module is missing is ``derive`` called to
write it (opty's habit: generated code carries the hash of its source, so stale code is never
used and never silently rebuilt).
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

from pulsemap.derive.cache import cache_dir
from pulsemap.derive.sources import (BALANCE_MODELS, PROFILE_KINDS, VARIANTS, BalanceSource, ForceSource, GeneratedCodeError,
                            MapSource, module_name, verify_generated)

PACKAGE_DIR = Path(__file__).resolve().parents[2] / "generated"


def _dirs() -> list[Path]:
    return [PACKAGE_DIR, cache_dir() / "generated"]


def _load_path(path: Path) -> ModuleType:
    try:
        verify_generated(path.read_text(encoding="utf-8"))
    except GeneratedCodeError as exc:
        raise RuntimeError(f"generated module {path}: {exc}") from None
    spec = importlib.util.spec_from_file_location(f"pulsemap_generated_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)  # our own generated, hash-checked file
    return module


def load_by_name(name: str) -> ModuleType:
    """Load generated module ``name`` (e.g. ``map_0123abcd...``) from generated/ or the cache."""
    for folder in _dirs():
        path = folder / f"{name}.py"
        if path.is_file():
            return _load_path(path)
    raise FileNotFoundError(f"no generated module {name}: run the scene once to generate it")


def _ensure(source) -> ModuleType:
    try:
        return load_by_name(module_name(source))
    except FileNotFoundError:
        pass
    from pulsemap.derive import codegen  # only now: the code is missing and must be generated

    return _load_path(codegen.write(source))


def _check_profile(profile: str) -> None:
    if profile not in PROFILE_KINDS:
        raise ValueError(f"unknown profile {profile!r}: choose one of {', '.join(PROFILE_KINDS)}")


def map_module(R_text: str, params, n: float, profile: str = "exact", variant: str = "paper",
               site_dependent=()) -> ModuleType:
    """The generated map module (Eq. 23, one variant) for this source, generating it if missing."""
    if variant not in VARIANTS:
        raise ValueError(f"unknown map variant {variant!r}: choose one of {', '.join(VARIANTS)}")
    _check_profile(profile)
    return _ensure(MapSource.of(R_text, params, n, profile, variant, site_dependent))


def force_module(R_text: str, params) -> ModuleType:
    """The generated on-site force module for R, generating it if missing."""
    return _ensure(ForceSource.of(R_text, params))


def balance_module(R_text: str, params, n: float, profile: str = "exact", model: str = "energy",
                   site_dependent=()) -> ModuleType:
    """The generated energy- or momentum-balance module for this source, generating it if missing.

    Raises pulsemap.derive.balance.BalanceError (a ValueError) when the model is undefined for R.
    """
    if model not in BALANCE_MODELS:
        raise ValueError(f"unknown balance model {model!r}: choose one of {', '.join(BALANCE_MODELS)}")
    _check_profile(profile)
    return _ensure(BalanceSource.of(R_text, params, n, profile, model, site_dependent))
