"""Reports of the profile layer (``pulsemap profile``): data first, text from the data."""

from __future__ import annotations

from .integrals import F_NAMES, constants
from .sources import DEFAULT_DPS
from .profile import check_exponent, check_profile_kind, exact_profile, pade_profile
from .provenance import provenance


def profile_report(n: float = 1.5, profile: str = "exact", dps: int | None = None) -> dict:
    """S(0), half width, Eq. 4 residual, Pade q's with fit error, f1..f7 (Eqs. 4, 5, 17, 22)."""
    n = check_exponent(n)
    profile = check_profile_kind(profile)
    exact = exact_profile(n)
    pade = pade_profile(n)
    consts = constants(F_NAMES, n=n, profile=profile, dps=dps)
    chosen = exact if profile == "exact" else pade
    return {
        "provenance": provenance(),
        "n": n,
        "profile": profile,
        "S0": exact.S0,
        "half_width": exact.half_width,
        "residual_eq4": exact.residual,
        "accuracy": exact.accuracy,
        "petviashvili_iterations": exact.iterations,
        "pade": {
            "q": dict(zip(("q0", "q2", "q4", "q6", "q8"), pade.q)),
            "fit_error": pade.accuracy,
            "residual_eq4": pade.residual,
            "half_width": pade.half_width,
        },
        "constants_profile": {"kind": profile, "S0": chosen.S0, "accuracy": chosen.accuracy},
        "dps": dps if dps is not None else DEFAULT_DPS[profile],
        **{name: consts[name].value for name in F_NAMES},
        "errors": {name: consts[name].error for name in F_NAMES},
    }


def profile_text(report: dict) -> str:
    """Human-readable rendering of :func:`profile_report`."""
    lines = [
        f"solitary wave of Eq. 4, n = {report['n']:g} (exact profile, Petviashvili/FFT, "
        f"{report['petviashvili_iterations']} iterations)",
        f"  S(0)            = {report['S0']:.15g}",
        f"  half width      = {report['half_width']:.12g}   (S = S(0)/2)",
        f"  Eq. 4 residual  = {report['residual_eq4']:.2e}   (max |S'' - rhs| / S(0))",
        "Pade form of Eq. 5, fitted (q0 = S(0)^-1/2):",
    ]
    for name, value in report["pade"]["q"].items():
        lines.append(f"  {name} = {value:.15g}")
    lines.append(
        f"  fit error = {report['pade']['fit_error']:.2e} (max |S_pade - S| / S(0)); "
        f"its Eq. 4 residual = {report['pade']['residual_eq4']:.2e}"
    )
    lines.append(
        f"universal constants (Eqs. 17, 22) for the {report['profile']} profile, "
        f"mpmath dps {report['dps']}:"
    )
    for name in F_NAMES:
        note = {"f5": "  (= f2)", "f6": "  (= f3)", "f7": "  (dropped delta_{i+2} term)"}.get(name, "")
        lines.append(f"  {name} = {report[name]:.15g}  +- {report['errors'][name]:.1e}{note}")
    return "\n".join(lines)
