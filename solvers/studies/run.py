"""Run a scene: DNS, map and long-wave law side by side, with errors and timings (DESIGN.md).

Only what the scene asks for is computed: no DNS unless "dns" is among its methods (the map is
then seeded from v0 through kappa_n), no long-wave law for a site-dependent perturbation, and a
chain only as long as the contacts need. In a run with the DNS, the map and the law start from
the DNS peak at the last unperturbed contact (first_perturbed - 1), converted by Eq. 32.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from types import ModuleType
from typing import Sequence

import numpy as np

from pulsemap.derive.provenance import provenance
from pulsemap.solvers import __version__
from pulsemap.solvers.models.balance_eval import evaluate_balance_law, iterate_balance_map
from pulsemap.solvers.models.codeload import balance_module, force_module, map_module
from pulsemap.solvers.chain.dns import OnSiteForce, simulate
from pulsemap.solvers.models.longwave_eval import evaluate_law
from pulsemap.solvers.models.map_iteration import contact_params, eps0_ratio, iterate_map
from pulsemap.solvers.studies.points import chain_force, dns_span, on_contacts
from pulsemap.solvers.data.scene import METHODS, PROFILES, VARIANTS, Scene, SceneError, check_choice
from pulsemap.solvers.studies.sweep import SweepError

EPS_WARN = 0.3  # eps above this is outside the map's asymptotic assumption (eps << 1)

#: Every reduced model run_scene offers (all methods but the DNS), in canonical order.
MODELS: tuple[str, ...] = tuple(m for m in METHODS if m != "dns")
#: The balance models (derive/balance.py): method -> (balanced quantity, form).
BALANCE_METHODS = {
    "energy-map": ("energy", "map"),
    "energy-law": ("energy", "law"),
    "momentum-map": ("momentum", "map"),
    "momentum-law": ("momentum", "law"),
}
#: What each model is, for outputs that name it.
MODEL_TITLES = {
    "map": "amplitude map (paper Eq. 23)",
    "longwave": "long-wave law (paper Eq. 30)",
    "energy-map": "energy-balance map: E_1 A_i^(n+1) = E_1 A_(i-1)^(n+1) + W(A_(i-1))",
    "energy-law": "energy-balance law: E_1 dA^(n+1)/di = W(A)",
    "momentum-map": "momentum-balance map: p_1 A_i^(1+s) = p_1 A_(i-1)^(1+s) + J(A_(i-1))",
    "momentum-law": "momentum-balance law: p_1 dA^(1+s)/di = J(A)",
}
FORCING_WARN = 0.3  # eps term of Eq. 23 above this fraction of the contact term: same assumption, per contact
DRIFT_WARN = 0.05  # the 'paper' map's own drift at eps = 0 over the contacts run (ERRATA item 5)
WIDTH_WARN = 0.01  # f7/f1: the delta_{i+2} integral Eq. 9 drops, relative to the contact term f1


class RunError(ValueError):
    """A scene that cannot be run as asked."""


@dataclass(frozen=True)
class Choice:
    """Profile and map variant of a run (scene defaults unless overridden)."""

    profile: str
    variant: str


def _params(scene: Scene, beads: int | None) -> dict:
    """Parameter values: scalars, or per-bead arrays when the scene fixes the chain length."""
    pert = scene.perturbation
    out = {}
    for name in pert.used_parameters:
        if name not in pert.site_dependent:
            out[name] = float(pert.params[name])
        elif beads is None:
            raise RunError(f"parameter '{name}' varies along the chain: set [chain] beads")
        else:
            out[name] = pert.bead_values(name, beads)
    return out


def make_force(scene: Scene, beads: int) -> OnSiteForce:
    """eps_i R_i(x_i, v_i) for the DNS from the generated force module (zero before first_perturbed):
    points.chain_force, refused unless R(0, 0) = 0 on every bead (the chain starts at rest)."""
    pert = scene.perturbation
    mod = force_module(pert.text, pert.used_parameters)
    chain = {"beads": beads, "first_perturbed": scene.first_perturbed, "eps": float(pert.eps)}
    values = _params(scene, beads)
    zeros = np.zeros(beads)
    try:
        force = chain_force(mod, chain, values)
        with np.errstate(all="ignore"):
            f0 = np.asarray(force.force(zeros, zeros), dtype=float)
    except SweepError as exc:
        raise RunError(str(exc)) from None
    except (ValueError, ZeroDivisionError, FloatingPointError) as exc:
        raise RunError(f"the on-site force cannot be evaluated at rest: {exc}") from None
    if not np.all(np.isfinite(f0)):
        raise RunError("the on-site force is undefined at rest (non-finite value): check R and its parameters")
    if np.any(np.abs(f0) > 1e-12):
        k = int(np.argmax(np.abs(f0)))
        eps_k = float(pert.eps) if k + 1 >= scene.first_perturbed else 0.0
        raise RunError(f"R(0, 0) = {f0[k] / max(eps_k, 1e-300):.6g} at bead {k + 1}: the chain would not start at rest")
    return force


STRONG_FRACTION = 0.1  # "strong" contacts: DNS peak at least this fraction of the seed peak


def _errors(ref: list, alive: list, values: list, seed_peak: float | None = None) -> dict:
    """Max and RMS relative error of ``values`` against the live DNS peaks.

    ``max_rel_strong``: the max over contacts whose DNS peak is at least STRONG_FRACTION of the
    seed peak (near extinction relative errors of any model approach 100 %).
    """
    out = _rel_errors(ref, alive, values)
    if seed_peak is not None:
        strong = [a and r is not None and r >= STRONG_FRACTION * seed_peak for r, a in zip(ref, alive)]
        strong_errors = _rel_errors(ref, strong, values)
        out["max_rel_strong"] = strong_errors["max_rel"]
        out["max_rel_strong_all"] = strong_errors.get("max_rel_all")
    return out


def _rel_errors(ref: list, alive: list, values: list) -> dict:
    """Max/RMS relative error where the model has a value; ``*_all``: over every live contact, a
    model that has ended (no value) counting as predicting 0 (relative error 1), for rankings."""
    rel = []
    missing = 0
    for r, a, v in zip(ref, alive, values):
        if not a or r is None:
            continue
        if v is None:
            missing += 1
            continue
        rel.append(abs(v - r) / abs(r))
    if not rel:
        out = {"max_rel": None, "rms_rel": None, "compared": 0, "missing": missing}
        out.update(max_rel_all=1.0 if missing else None, rms_rel_all=1.0 if missing else None)
        return out
    arr = np.array(rel)
    full = np.concatenate([arr, np.ones(missing)])
    return {"max_rel": float(arr.max()), "rms_rel": float(np.sqrt(np.mean(arr**2))), "compared": int(arr.size),
            "missing": missing, "max_rel_all": float(full.max()), "rms_rel_all": float(np.sqrt(np.mean(full**2)))}


def _eps0_drift(mod, seed_contact: int, last: int, prm: dict) -> float | None:
    """Relative change of A over contacts seed_contact+1..last when eps = 0 (0 for 'corrected' and '1d')."""
    ratio = eps0_ratio(mod, contact_params(mod, prm, seed_contact + 1))
    return None if ratio is None else ratio ** (last - seed_contact) - 1.0


def _width_warning(mod) -> str | None:
    """Eq. 9 assumes delta_{i+2} = 0 while contact i is compressed: false for a wide pulse (n near 1)."""
    ratio = float(mod.f7) / float(mod.f1)
    if ratio <= WIDTH_WARN:
        return None
    return (f"the pulse spans more than two contacts at n = {float(mod.N_EXPONENT):g} (f7/f1 = {ratio:.3g} > "
            f"{WIDTH_WARN:g}): Eq. 9's assumption delta_(i+2) = 0 fails and the reduced models lose accuracy")


def run_scene(
    scene: Scene,
    *,
    methods: Sequence[str] | None = None,
    profile: str | None = None,
    variant: str | None = None,
    progress: bool = False,
    dns_window: "int | str | None" = None,
    reuse_dns: dict | None = None,
    seed_peak: float | None = None,
) -> dict:
    """Run ``scene`` and return the result as JSON-serialisable data (DESIGN.md contract).

    ``reuse_dns``: the result of an earlier run of the same scene with the DNS; its peaks (and
    its seed) are used instead of running the DNS again (for comparing profiles and variants).
    ``seed_peak``: a measured peak at contact first_perturbed - 1 to seed map and law with
    (converted by Eq. 32), instead of the DNS peak or v0 through kappa_n.
    """
    if seed_peak is not None and not (isinstance(seed_peak, (int, float)) and math.isfinite(seed_peak) and seed_peak > 0):
        raise RunError(f"seed peak must be a finite number > 0, got {seed_peak!r}")
    given_seed = seed_peak
    methods = tuple(methods) if methods is not None else tuple(scene.methods)
    try:  # every choice checked before anything runs (one-line error with the closest name)
        methods = tuple(check_choice(m.strip() if isinstance(m, str) else m, "method", METHODS) for m in methods)
        choice = Choice(check_choice(profile or scene.profile, "profile", PROFILES),
                        check_choice(variant or scene.variant, "map variant", VARIANTS))
    except SceneError as exc:
        raise RunError(str(exc)) from None
    c0, c1 = scene.contacts
    fp = scene.first_perturbed
    seed_contact = fp - 1
    pert = scene.perturbation
    site = pert.site_dependent
    timings: dict[str, float] = {}
    warnings: list[str] = []
    contacts = list(range(c0, c1 + 1))
    out: dict = {
        "pulsemap_version": __version__,
        "provenance": provenance(),  # package and library versions (derive/provenance.py)
        "scene": scene.as_dict(),
        "choices": {"profile": choice.profile, "variant": choice.variant, "methods": list(methods)},
        "contacts": contacts,
        "peaks": {"dns": None, **{m: None for m in MODELS}},
        "errors": {},
        "timings_s": timings,
        "warnings": warnings,
    }
    if pert.eps > EPS_WARN and any(m in MODELS for m in methods):
        warnings.append(f"eps = {pert.eps:g} is not small: the reduced models assume eps << 1")

    # ---------------------------------------------------------------- DNS
    dns_peaks = dns_alive = None
    if "dns" in methods:
        beads, span = dns_span(scene)
        t0 = time.perf_counter()
        force = make_force(scene, beads)
        timings["derive_force"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        res = simulate(
            beads, scene.exponent, scene.velocity, span, force,
            method=scene.dns.get("method", "auto"), rtol=float(scene.dns.get("rtol", 1e-10)),
            atol=float(scene.dns.get("atol", 1e-12)), progress=progress,
            **({"window": dns_window} if dns_window is not None else {}),
        )
        timings["dns"] = time.perf_counter() - t0
        dns_peaks = on_contacts(contacts, res.contacts, res.peaks, res.alive)
        dns_alive = [p is not None for p in dns_peaks]
        out["peaks"]["dns"] = dns_peaks
        out["dns"] = {
            "method": res.method, "rtol": res.rtol, "atol": res.atol, "beads": res.beads, "mode": res.mode,
            "stop_reason": res.stop_reason, "nfev": int(res.nfev),
            "alive": dns_alive,
            "live_contacts": [c for c, a in zip(contacts, dns_alive) if a],
        }
        if not all(dns_alive):
            dead = [c for c, a in zip(contacts, dns_alive) if not a]
            warnings.append(f"DNS: no live primary pulse at contacts {dead[0]}..{dead[-1]} ({res.stop_reason})")
        dns_seed = on_contacts([seed_contact], res.contacts, res.peaks, res.alive)[0]
        if dns_seed is not None:
            seed_peak = dns_seed
            out["dns"]["seed_peak"] = seed_peak  # peak at first_perturbed - 1, seeds map and law

    if reuse_dns is not None and "dns" not in methods:
        if reuse_dns.get("contacts") != contacts or reuse_dns["peaks"].get("dns") is None:
            raise RunError("reuse_dns must be a DNS run of the same scene and contacts")
        dns_peaks = reuse_dns["peaks"]["dns"]
        dns_alive = reuse_dns["dns"]["alive"]
        out["peaks"]["dns"] = dns_peaks
        out["dns"] = {**reuse_dns["dns"], "reused": True}
        seed_peak = reuse_dns["dns"].get("seed_peak")

    # ----------------------------------------------------------- models
    mod = None
    balance: dict[str, ModuleType] = {}
    if "map" in methods or "longwave" in methods:
        t0 = time.perf_counter()
        mod = map_module(pert.text, pert.used_parameters, scene.exponent, choice.profile, choice.variant, site)
        timings["derive_map"] = time.perf_counter() - t0
        wide = _width_warning(mod)
        if wide is not None:
            warnings.append(wide)
    for quantity in dict.fromkeys(BALANCE_METHODS[m][0] for m in methods if m in BALANCE_METHODS):
        t0 = time.perf_counter()
        try:
            balance[quantity] = balance_module(pert.text, pert.used_parameters, scene.exponent, choice.profile,
                                               quantity, site)
        except ValueError as exc:  # the model is undefined for this R (pulsemap.derive.balance.BalanceError)
            for m in methods:
                if BALANCE_METHODS.get(m, ("",))[0] == quantity:
                    warnings.append(f"{m} refused: {exc}")
                    out[m] = {"model": MODEL_TITLES[m], "refused": str(exc)}
        timings[f"derive_{quantity}"] = time.perf_counter() - t0
    if mod is not None or balance:
        S0 = float(mod.S0 if mod is not None else next(iter(balance.values())).S0)
        if given_seed is not None:
            seed_peak, seed_from = float(given_seed), "given peak (--seed-peak)"
        elif seed_peak is not None:
            seed_from = f"DNS peak at contact {seed_contact}"
        else:
            from pulsemap.solvers.chain.kappa import peak_from_velocity

            t0 = time.perf_counter()
            seed_peak = float(peak_from_velocity(scene.velocity, scene.exponent))
            timings["kappa"] = time.perf_counter() - t0
            seed_from = "impulse v0 through kappa_n (unperturbed incoming peak)"
        seed_A = seed_peak / S0
        out["seed"] = {"contact": seed_contact, "peak": seed_peak, "A": seed_A, "from": seed_from}
        prm = _params(scene, scene.beads)
        for m in methods:
            if m not in BALANCE_METHODS or BALANCE_METHODS[m][0] not in balance:
                continue
            bmod = balance[BALANCE_METHODS[m][0]]
            t0 = time.perf_counter()
            if BALANCE_METHODS[m][1] == "map":
                br = iterate_balance_map(bmod, seed_A, seed_contact, c1, float(pert.eps), prm)
            elif not bmod.UNIFORM:
                warnings.append(f"{m} skipped: the perturbation is site-dependent ("
                                + ", ".join(site or ("i",)) + "): use the balance map")
                continue
            else:
                br = evaluate_balance_law(bmod, seed_A, float(seed_contact), contacts, float(pert.eps), prm)
            timings[m] = time.perf_counter() - t0
            out["peaks"][m] = on_contacts(contacts, br.contacts, br.peaks)
            out[m] = {"model": MODEL_TITLES[m], "profile": br.profile, "status": br.status, "message": br.message,
                      "ended_at": br.ended_at, "law_kind": br.law_kind, "generated": bmod.__name__}
            if br.status != "ok":
                warnings.append(f"{m}: {br.message}")
        if "map" in methods:
            t0 = time.perf_counter()
            mr = iterate_map(mod, seed_A, seed_contact, c1, float(pert.eps), prm)
            timings["map"] = time.perf_counter() - t0
            out["peaks"]["map"] = on_contacts(contacts, mr.contacts, mr.peaks)
            out["map"] = {"model": MODEL_TITLES["map"], "variant": mr.variant, "profile": mr.profile, "status": mr.status,
                          "message": mr.message, "newton_fallbacks": mr.fallbacks,
                          "generated": mod.__name__}
            out["map"]["max_forcing_ratio"] = mr.max_forcing_ratio  # |eps term| / contact term (map_iteration)
            if mr.status != "ok":
                warnings.append(f"map: {mr.message}")
            if mr.variant == "paper":
                drift = _eps0_drift(mod, seed_contact, c1, prm)
                out["map"]["eps0_drift"] = drift
                if drift is not None and abs(drift) > DRIFT_WARN:
                    warnings.append(f"map: the 'paper' variant drifts by {100 * drift:+.3g} % over contacts "
                                    f"{seed_contact + 1}..{c1} even at eps = 0 (ERRATA item 5): use --variant corrected or 1d")
            if mr.max_forcing_ratio is not None and mr.max_forcing_ratio > FORCING_WARN:
                k = int(np.argmax(mr.forcing_ratio > FORCING_WARN))
                warnings.append(f"map: at contact {int(mr.contacts[k])} the eps term of Eq. 23 exceeds "
                                f"{FORCING_WARN:g} of the contact term (max {mr.max_forcing_ratio:.3g} over the run): "
                                "outside the map's assumption eps*R << contact forces")
        if "longwave" in methods:
            if site:
                warnings.append("long-wave law skipped: the perturbation is site-dependent (" + ", ".join(site) + ")")
            else:
                t0 = time.perf_counter()
                law = evaluate_law(mod, seed_A, float(seed_contact), contacts, float(pert.eps), prm)
                timings["longwave"] = time.perf_counter() - t0
                out["peaks"]["longwave"] = on_contacts(contacts, law.contacts, law.peaks)
                out["longwave"] = {"model": MODEL_TITLES["longwave"], "kind": law.kind, "ended_at": law.ended_at,
                                   "ended": law.ended or None,
                                   "profile": choice.profile}
                if law.ended:
                    warnings.append(f"long-wave law: {law.ended} at contact index {law.ended_at:.4g}")

    # ------------------------------------------------------------- errors
    if dns_peaks is not None:
        for name in MODELS:
            if out["peaks"][name] is not None:
                out["errors"][name] = _errors(dns_peaks, dns_alive, out["peaks"][name],
                                              out.get("seed", {}).get("peak"))
    return out


def _columns(result: dict) -> list[str]:
    """dns, map, longwave, then every other model that has peaks in this result."""
    extra = [m for m in MODELS if m not in ("map", "longwave") and result["peaks"].get(m) is not None]
    return ["dns", "map", "longwave"] + extra


def to_csv(result: dict) -> str:
    """One row per contact: contact, dns, map, longwave, other models run (empty where not computed)."""
    cols = _columns(result)
    lines = ["contact," + ",".join(cols) + ",dns_alive"]
    alive = (result.get("dns") or {}).get("alive") or [None] * len(result["contacts"])
    for k, c in enumerate(result["contacts"]):
        row = [str(c)]
        for name in cols:
            vals = result["peaks"][name]
            row.append("" if vals is None or vals[k] is None else repr(vals[k]))
        row.append("" if alive[k] is None else str(bool(alive[k])).lower())
        lines.append(",".join(row))
    return "\n".join(lines) + "\n"


def to_text(result: dict) -> str:
    """A short human-readable summary of a run."""
    sc = result["scene"]
    ch = result["choices"]
    lines = [
        f"scene {sc['name']}: R = {sc['perturbation']['R']}, eps = {sc['perturbation']['eps']}, "
        f"v0 = {sc['excitation']['velocity']}, contacts {result['contacts'][0]}..{result['contacts'][-1]}",
        f"  profile {ch['profile']}, map variant {ch['variant']}, methods {', '.join(ch['methods'])}",
    ]
    if "seed" in result:
        s = result["seed"]
        lines.append(f"  seed: A_{s['contact']} = {s['A']:.6g} (peak {s['peak']:.6g}, from {s['from']})")
    if "dns" in result:
        d = result["dns"]
        lines.append(f"  DNS: {d['method']} rtol {d['rtol']:g}, {d['beads']} beads, {d['stop_reason']}")
    for name in MODELS:
        if isinstance(result.get(name), dict):
            info = result[name]
            status = f" [{info['refused']}]" if "refused" in info else ""
            lines.append(f"  {name}: {info.get('model', '')}{status}")
    for name, err in result["errors"].items():
        if err["max_rel"] is None:
            lines.append(f"  {name:8s} vs DNS: nothing to compare ({err['missing']} live contacts without a value)")
        else:
            lines.append(
                f"  {name:8s} vs DNS: max rel {err['max_rel']:.3g}, rms rel {err['rms_rel']:.3g} over "
                f"{err['compared']} live contacts" + (f" ({err['missing']} without a value)" if err["missing"] else "")
                + (f"; max rel {err['max_rel_strong']:.3g} while the DNS peak >= 10 % of its entry value"
                   if err.get("max_rel_strong") is not None else "")
            )
    t = result["timings_s"]
    lines.append("  time: " + ", ".join(f"{k} {v:.4g} s" for k, v in t.items()))
    cols = _columns(result)
    lines.append(f"  {'contact':>7s} " + " ".join(f"{c:>12s}" for c in cols))
    step = max(1, len(result["contacts"]) // 12)
    for k in range(0, len(result["contacts"]), step):
        row = [f"  {result['contacts'][k]:7d}"]
        for name in cols:
            vals = result["peaks"][name]
            row.append(f"{'-' if vals is None or vals[k] is None else format(vals[k], '.6g'):>12s}")
        lines.append(" ".join(row))
    for w in result["warnings"]:
        lines.append(f"  warning: {w}")
    return "\n".join(lines)


def plot(result: dict, path: str, log_y: bool = False) -> None:
    """The paper's style: DNS as +, map as dots, long-wave law as a line, the DNS's stop marked
    (data/plotting.peaks_figure; matplotlib, optional)."""
    from pulsemap.solvers.data.plotting import peaks_figure, pyplot, save

    plt = pyplot(RunError)
    save(peaks_figure(result, plt, log_y), plt, path)
