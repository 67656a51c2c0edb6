"""What a generated module depends on, and the hash it is looked up by (no sympy here).

Kept free of sympy so that ``solvers`` can find generated code without importing the symbolic
side; ``derive.codegen`` produces the code for a source that is missing.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from fractions import Fraction
from typing import Union

GENERATOR_VERSION = 1
#: Bump together with derive.integrals.METHOD_VERSION (checked by a test).
INTEGRALS_METHOD = 1
#: Bump together with derive.balance.BALANCE_METHOD (checked by a test).
BALANCE_METHOD = 1
VARIANTS = ("paper", "corrected", "1d")
DEFAULT_DPS = {"exact": 16, "pade": 30}


def normalize_expression(text: str) -> str:
    """The expression text as a lookup key: whitespace removed, '^' written as '**'."""
    return "".join(str(text).split()).replace("^", "**")


def exact_n(n) -> str:
    """n as an exact rational string ("3/2" for 1.5)."""
    return str(Fraction(str(n)))


@dataclass(frozen=True)
class MapSource:
    """Everything a generated map module depends on."""

    R: str  # normalized expression text
    params: tuple[str, ...]  # parameter names of R, sorted
    site_dependent: tuple[str, ...]
    n: str  # exact rational, e.g. "3/2"
    profile: str
    variant: str
    dps: int

    @classmethod
    def of(cls, R: str, params, n, profile: str = "exact", variant: str = "paper", site_dependent=(), dps=None):
        return cls(
            R=normalize_expression(R),
            params=tuple(sorted(params)),
            site_dependent=tuple(sorted(site_dependent)),
            n=exact_n(n),
            profile=profile,
            variant=variant,
            dps=int(dps if dps is not None else DEFAULT_DPS.get(profile, 16)),
        )

    def as_dict(self) -> dict:
        return {
            "kind": "map",
            "R": self.R,
            "params": list(self.params),
            "site_dependent": list(self.site_dependent),
            "n": self.n,
            "profile": self.profile,
            "variant": self.variant,
            "dps": self.dps,
            "integrals_method": INTEGRALS_METHOD,
            "generator": GENERATOR_VERSION,
        }


@dataclass(frozen=True)
class ForceSource:
    """Everything a generated on-site force module depends on."""

    R: str
    params: tuple[str, ...]

    @classmethod
    def of(cls, R: str, params):
        return cls(R=normalize_expression(R), params=tuple(sorted(params)))

    def as_dict(self) -> dict:
        return {"kind": "force", "R": self.R, "params": list(self.params), "generator": GENERATOR_VERSION}


@dataclass(frozen=True)
class BalanceSource:
    """Everything a generated energy- or momentum-balance module depends on (derive/balance.py)."""

    R: str
    params: tuple[str, ...]
    site_dependent: tuple[str, ...]
    n: str
    profile: str
    model: str  # "energy" or "momentum"
    dps: int

    @classmethod
    def of(cls, R: str, params, n, profile: str = "exact", model: str = "energy", site_dependent=(), dps=None):
        return cls(
            R=normalize_expression(R),
            params=tuple(sorted(params)),
            site_dependent=tuple(sorted(site_dependent)),
            n=exact_n(n),
            profile=profile,
            model=model,
            dps=int(dps if dps is not None else DEFAULT_DPS.get(profile, 16)),
        )

    def as_dict(self) -> dict:
        return {
            "kind": "balance",
            "R": self.R,
            "params": list(self.params),
            "site_dependent": list(self.site_dependent),
            "n": self.n,
            "profile": self.profile,
            "model": self.model,
            "dps": self.dps,
            "balance_method": BALANCE_METHOD,
            "generator": GENERATOR_VERSION,
        }


Source = Union[MapSource, ForceSource, BalanceSource]


def source_from_dict(d: dict) -> Source:
    if d["kind"] == "map":
        return MapSource(d["R"], tuple(d["params"]), tuple(d["site_dependent"]), d["n"], d["profile"], d["variant"], int(d["dps"]))
    if d["kind"] == "balance":
        return BalanceSource(d["R"], tuple(d["params"]), tuple(d["site_dependent"]), d["n"], d["profile"], d["model"], int(d["dps"]))
    return ForceSource(d["R"], tuple(d["params"]))


def source_hash(source: Source) -> str:
    """The hash a generated module is looked up by (sha256 of its source, canonical JSON)."""
    return hashlib.sha256(json.dumps(source.as_dict(), sort_keys=True).encode()).hexdigest()


def module_name(source: Source) -> str:
    kind = {MapSource: "map", ForceSource: "force", BalanceSource: "balance"}[type(source)]
    return f"{kind}_{source_hash(source)[:16]}"


class GeneratedCodeError(ValueError):
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
