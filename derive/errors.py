"""The project's own error and its "did you mean": the base every pulsemap error derives from, and the
one closest-name lookup every message that suggests a name uses."""

from __future__ import annotations

import difflib
from typing import Iterable


class PulsemapError(ValueError):
    """A problem with what was asked (an argument, a scene, an expression, a model R cannot have): its
    message is one line naming it and the fix. The command line prints only these (and OSError) as
    ``pulsemap: error: ...`` with exit status 2; any other exception is a bug in pulsemap."""


def closest(word: str, known: Iterable[str], cutoff: float = 0.6) -> str | None:
    """The name of ``known`` closest to ``word``: the one equal to it but for case, else difflib's closest
    at ratio >= ``cutoff``; None when none is that close."""
    known = list(known)
    text = str(word)
    for name in known:
        if name.lower() == text.lower():
            return name
    match = difflib.get_close_matches(text, known, n=1, cutoff=cutoff)
    return match[0] if match else None
