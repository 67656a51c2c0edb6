"""Write numpy-only solver modules for a perturbation into ``generated/`` (or the cache).

Three kinds of module, each generated only when a scene needs it:

* ``map_<hash>.py``     the residuals of the map equations (Eq. 23, one variant) with their
                        Jacobian, the long-wave right-hand side (Eq. 30) and closed-form law, and
                        the stationary function of Eq. 41 with its derivatives (derive/codegen_map.py);
* ``balance_<hash>.py`` an energy- or momentum-balance map step and law (derive/codegen_balance.py);
* ``force_<hash>.py``   the on-site force eps_i R_i(x_i, v_i) of the DNS (Eq. 1), vectorised over
                        beads, with dF/dx and dF/dv for implicit integrators (derive/codegen_force.py);
* ``jitforce_<hash>.py`` the same force for one bead as numba C callables, for the compiled DNS when R
                        is not a polynomial (cache only; derive/codegen_jitforce.py).

Every file starts with a header naming its source (expression, n, profile, variant) and two
hashes: ``source-hash`` (what the file is looked up by; it names everything the content depends
on) and ``content-hash`` (of the code below the header; a file whose content does not match it
was edited by hand and is refused). A constant computed by quadrature (and S(0)) is embedded rounded
at the decade of its error bound (derive/codeprint.py ``measured``; about 1e-10, at most 12 significant
digits), so noise far below its accuracy leaves the file byte-identical on every machine. The
user's parameters are arguments with a prefix no identifier of the module has (derive/codeprint.py).
"""

from __future__ import annotations

from pathlib import Path

from . import cache
from .amplitude_map import check_variant
from .codegen_balance import generate_balance
from .codegen_force import generate_force
from .codegen_jitforce import generate_jit_force
from .codegen_map import generate_map
from .codeprint import SIG_DIGITS, CodegenError
from .files import WriteError, describe_os_error, write_atomic
from .profile import check_profile_kind
from .sources import BalanceSource, ForceSource, JitForceSource, MapSource, module_name

__all__ = [
    "PACKAGE_DIR", "SIG_DIGITS", "BalanceSource", "CodegenError", "ForceSource", "MapSource",
    "balance_source", "force_source", "generate_balance", "generate_force", "generate_map",
    "map_source", "module_name", "write",
]

PACKAGE_DIR = Path(__file__).resolve().parent.parent / "generated"


def map_source(R_text: str, params, n, profile: str = "exact", variant: str = "paper", site_dependent=(), dps: int | None = None) -> MapSource:
    """The MapSource for R (text in u, v, i and parameters), validated."""
    check_profile_kind(profile)
    check_variant(variant)
    return MapSource.of(R_text, params, n, profile, variant, site_dependent, dps)


def force_source(R_text: str, params) -> ForceSource:
    return ForceSource.of(R_text, params)


def balance_source(R_text: str, params, n, profile: str = "exact", model: str = "energy", site_dependent=(), dps: int | None = None) -> BalanceSource:
    """The BalanceSource for R (energy- or momentum-balance model, derive/balance.py), validated."""
    from .balance import check_model

    check_profile_kind(profile)
    check_model(model)
    return BalanceSource.of(R_text, params, n, profile, model, site_dependent, dps)


def _generate(source) -> str:
    if isinstance(source, MapSource):
        return generate_map(source)
    if isinstance(source, BalanceSource):
        return generate_balance(source)
    if isinstance(source, JitForceSource):
        return generate_jit_force(source)
    return generate_force(source)


def write(source: MapSource | ForceSource | JitForceSource | BalanceSource, directory: Path | None = None) -> Path:
    """Generate the module for ``source`` into ``directory`` (default: the cache, or a private temporary
    folder when its place there is taken: cache.generated_path)."""
    text = _generate(source)
    if directory is None:
        path = cache.generated_path(module_name(source) + ".py")
    else:
        Path(directory).mkdir(parents=True, exist_ok=True)
        path = Path(directory) / (module_name(source) + ".py")
    try:
        write_atomic(path, text)
    except OSError as exc:
        raise WriteError(describe_os_error(exc, path, "the generated module")) from None
    return path
