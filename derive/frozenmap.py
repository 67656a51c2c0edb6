"""An immutable, hashable mapping (sympy-free, shared by the perturbation and scene layers)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterator, Mapping


@dataclass(frozen=True, eq=False)
class FrozenMap(Mapping[str, Any]):
    """An immutable, hashable mapping that keeps its insertion order."""

    items_: tuple[tuple[str, Any], ...] = ()

    def __getitem__(self, key: str) -> Any:
        for name, value in self.items_:
            if name == key:
                return value
        raise KeyError(key)

    def __iter__(self) -> Iterator[str]:
        return (name for name, _ in self.items_)

    def __len__(self) -> int:
        return len(self.items_)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Mapping):
            return NotImplemented
        return dict(self.items_) == dict(other.items())

    def __hash__(self) -> int:
        return hash(frozenset(self.items_))

    def __repr__(self) -> str:
        return "FrozenMap(" + repr(dict(self.items_)) + ")"
