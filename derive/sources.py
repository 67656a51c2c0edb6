"""What a generated module depends on, and the hash it is looked up by (no sympy here).

Kept free of sympy so that ``solvers`` can find generated code without importing the symbolic
side; ``pulsemap.symbolic.codegen`` produces the code for a source that is missing.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, fields
from fractions import Fraction
from typing import ClassVar, Union

from pulsemap.symbolic.errors import PulsemapError

GENERATOR_VERSION = 3  # 2: parameters are arguments p_<name>, b<offset>_<name>; ARGS in map and balance modules
#: Bump when the force module's layout changes (2: MONOMIALS and monomial_coefficients, for the compiled DNS;
#: 3: R evaluated only on beads with eps_i != 0).
FORCE_LAYOUT = 3
#: Bump when the numba force module's layout changes (derive/codegen_jitforce.py; 2: R skipped where eps_i = 0).
JIT_FORCE_LAYOUT = 2
#: Bump when the numerical method of the profile integrals changes (stale cache entries, generated code).
INTEGRALS_METHOD = 1
#: Bump when the numerical method of the balance constants changes (stale cache entries, generated code).
BALANCE_METHOD = 1
#: Bump when the numerical method of the contact-law integrals I_ab changes (stale cache entries).
CONTACT_METHOD = 1
#: The map variants (derive/amplitude_map.py), profiles (derive/profile.py) and balance models (derive/balance.py).
VARIANTS = ("paper", "corrected", "1d")
PROFILE_KINDS = ("exact", "pade")
BALANCE_MODELS = ("energy", "momentum")
#: Default mpmath working precision (decimal digits) for the exact and Pade profiles.
DEFAULT_DPS = {"exact": 16, "pade": 30}


def normalize_expression(text: str) -> str:
    """The expression text as a lookup key: whitespace removed, '^' written as '**'."""
    return "".join(str(text).split()).replace("^", "**")


def exact_n(n) -> str:
    """n as an exact rational string ("3/2" for 1.5)."""
    return str(Fraction(str(n)))


@dataclass(frozen=True)
class _ExpandedSource:
    """The fields a map or balance module shares: R, its parameters, n and the profile.

    A subclass adds its own fields (variant or model, then dps) and names its KIND and METHOD.
    """

    R: str  # normalized expression text
    params: tuple[str, ...]  # parameter names of R, sorted
    site_dependent: tuple[str, ...]
    n: str  # exact rational, e.g. "3/2"
    profile: str

    KIND: ClassVar[str]
    METHOD: ClassVar[tuple[str, int]]  # the method version the hash includes

    @staticmethod
    def _normalized(R: str, params, n, profile: str, site_dependent, dps) -> dict:
        """The shared fields and dps, normalized (the keyword arguments of ``of``)."""
        return dict(
            R=normalize_expression(R),
            params=tuple(sorted(params)),
            site_dependent=tuple(sorted(site_dependent)),
            n=exact_n(n),
            profile=profile,
            dps=int(dps if dps is not None else DEFAULT_DPS.get(profile, 16)),
        )

    @classmethod
    def from_dict(cls, d: dict):
        """The source of ``as_dict``'s output."""
        values = {f.name: d[f.name] for f in fields(cls)}
        return cls(**{**values, "params": tuple(values["params"]), "site_dependent": tuple(values["site_dependent"]),
                      "dps": int(values["dps"])})

    def as_dict(self) -> dict:
        d = {"kind": self.KIND}
        for f in fields(self):
            value = getattr(self, f.name)
            d[f.name] = list(value) if isinstance(value, tuple) else value
        d[self.METHOD[0]] = self.METHOD[1]
        d["generator"] = GENERATOR_VERSION
        return d


@dataclass(frozen=True)
class MapSource(_ExpandedSource):
    """Everything a generated map module depends on."""

    variant: str
    dps: int

    KIND: ClassVar[str] = "map"
    METHOD: ClassVar[tuple[str, int]] = ("integrals_method", INTEGRALS_METHOD)

    @classmethod
    def of(cls, R: str, params, n, profile: str = "exact", variant: str = "paper", site_dependent=(), dps=None):
        return cls(variant=variant, **cls._normalized(R, params, n, profile, site_dependent, dps))


@dataclass(frozen=True)
class ForceSource:
    """Everything a generated on-site force module depends on."""

    R: str
    params: tuple[str, ...]

    @classmethod
    def of(cls, R: str, params):
        return cls(R=normalize_expression(R), params=tuple(sorted(params)))

    def as_dict(self) -> dict:
        return {"kind": "force", "R": self.R, "params": list(self.params), "generator": GENERATOR_VERSION,
                "layout": FORCE_LAYOUT}


@dataclass(frozen=True)
class JitForceSource(ForceSource):
    """Everything a generated numba force module (the compiled DNS's non-polynomial R) depends on."""

    def as_dict(self) -> dict:
        return {"kind": "jitforce", "R": self.R, "params": list(self.params), "generator": GENERATOR_VERSION,
                "layout": JIT_FORCE_LAYOUT}


@dataclass(frozen=True)
class BalanceSource(_ExpandedSource):
    """Everything a generated energy- or momentum-balance module depends on (derive/balance.py)."""

    model: str  # "energy" or "momentum"
    dps: int

    KIND: ClassVar[str] = "balance"
    METHOD: ClassVar[tuple[str, int]] = ("balance_method", BALANCE_METHOD)

    @classmethod
    def of(cls, R: str, params, n, profile: str = "exact", model: str = "energy", site_dependent=(), dps=None):
        return cls(model=model, **cls._normalized(R, params, n, profile, site_dependent, dps))


Source = Union[MapSource, ForceSource, JitForceSource, BalanceSource]


def source_from_dict(d: dict) -> Source:
    if d["kind"] == "map":
        return MapSource.from_dict(d)
    if d["kind"] == "balance":
        return BalanceSource.from_dict(d)
    if d["kind"] == "jitforce":
        return JitForceSource(d["R"], tuple(d["params"]))
    return ForceSource(d["R"], tuple(d["params"]))


def source_hash(source: Source) -> str:
    """The hash a generated module is looked up by (sha256 of its source, canonical JSON)."""
    return hashlib.sha256(json.dumps(source.as_dict(), sort_keys=True).encode()).hexdigest()


def module_name(source: Source) -> str:
    kind = {MapSource: "map", ForceSource: "force", JitForceSource: "jitforce", BalanceSource: "balance"}[type(source)]
    return f"{kind}_{source_hash(source)[:16]}"


class GeneratedCodeError(PulsemapError):
    """A generated file that is not ours or does not match its hashes."""


def split_generated(text: str) -> tuple[dict, str, str, str]:
    """(source dict, source-hash, content-hash, body) of a generated file's text."""
    first = text.find('"""')
    end = text.find('"""\n', first + 3)
    if first < 0 or end < 0:
        raise GeneratedCodeError("not a pulsemap generated file (no header docstring)")
    head, body = text[: end + 4], text[end + 4 :]
    fields = {}
    for line in head.splitlines():
        for key in ("source", "source-hash", "content-hash"):
            if line.startswith(key + ": "):
                fields[key] = line[len(key) + 2 :]
    if set(fields) != {"source", "source-hash", "content-hash"}:
        raise GeneratedCodeError("not a pulsemap generated file (header missing)")
    return json.loads(fields["source"]), fields["source-hash"], fields["content-hash"], body


def verify_generated(text: str) -> dict:
    """Check a generated file's content and source hashes; return its source dict."""
    source, shash, chash, body = split_generated(text)
    if hashlib.sha256(body.encode()).hexdigest() != chash:
        raise GeneratedCodeError(
            "generated code does not match its content-hash (edited by hand?): delete the file "
            "and let pulsemap regenerate it"
        )
    if hashlib.sha256(json.dumps(source, sort_keys=True).encode()).hexdigest() != shash:
        raise GeneratedCodeError("generated code's source-hash does not match its source: delete the file")
    return source
