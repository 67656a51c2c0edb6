"""Bounds on a scene file checked before it is parsed: size, nesting depth, key length and parts.

:mod:`tomllib` recurses once per nested array or inline table (500 levels: RecursionError) and
builds a dotted key part by part (a 20,000-part key in a 40 KB file took 2.4 GB). A scene needs
none of that: its deepest value is a random draw ``{uniform = [0, 1], seed = 7}`` under
``[perturbation.params]``. :func:`check_toml_bounds` is one linear pass over the text that skips
strings and comments, tracks the brackets of values and measures every key (bare, quoted or
dotted, in a table header or before ``=``); it raises :class:`TomlBoundsError` with a one-line
message at the first bound exceeded. Text it cannot follow (an unterminated string) is left to
tomllib, which reports the syntax error.
"""

from __future__ import annotations

import re

from pulsemap.symbolic.errors import PulsemapError

MAX_SCENE_BYTES = 64 * 1024 * 1024
"""Largest scene file read: room for per-bead lists of a few parameters at 1,000,000 beads."""
MAX_DEPTH = 16
"""Deepest nesting of arrays and inline tables in a value."""
MAX_KEY_PARTS = 8
"""Most parts of one dotted key (``perturbation.params.mu`` has 3)."""
MAX_KEY_CHARS = 200
"""Longest key, all its parts and quotes included."""


_VALUE_STOP = re.compile(r"[\n#\"'\[\]{},]")


class TomlBoundsError(PulsemapError):
    """A scene file beyond the bounds above (the message says which, where, and the bound)."""


def check_size(size: int) -> None:
    """Refuse a file of ``size`` bytes beyond MAX_SCENE_BYTES (before it is read)."""
    if size > MAX_SCENE_BYTES:
        raise TomlBoundsError(f"the file is {size} bytes, more than the {MAX_SCENE_BYTES} a scene may have: "
                              "a scene file holds a few tables of numbers")


def _string_end(text: str, i: int) -> int:
    """Index just past the string (basic, literal, multi-line) starting at ``text[i]``; -1 if unterminated."""
    quote = text[i]
    if text.startswith(quote * 3, i):
        j = text.find(quote * 3, i + 3)
        if quote == '"':  # an escaped quote does not end it
            while j != -1 and _escaped(text, j):
                j = text.find(quote * 3, j + 1)
        if j == -1:
            return -1
        while text.startswith(quote, j + 3):  # up to two quotes may end the content: """a""""
            j += 1
        return j + 3
    j = i + 1
    while True:
        k = text.find(quote, j)
        newline = text.find("\n", j)
        if k == -1 or (newline != -1 and newline < k):
            return -1
        if quote == '"' and _escaped(text, k):
            j = k + 1
            continue
        return k + 1


def _escaped(text: str, k: int) -> bool:
    """True if the character at ``k`` follows an odd number of backslashes."""
    n = 0
    while k - 1 - n >= 0 and text[k - 1 - n] == "\\":
        n += 1
    return n % 2 == 1


def check_toml_bounds(text: str) -> None:
    """Raise TomlBoundsError if ``text`` is larger than MAX_SCENE_BYTES characters, nests values deeper than MAX_DEPTH or has a key longer than
    MAX_KEY_CHARS or of more than MAX_KEY_PARTS parts (one pass, linear in the text)."""
    check_size(len(text))
    stack: list[str] = []  # open '[' (array) and '{' (inline table) of the current value
    in_key, header = True, False  # a key starts each top-level line, and follows '{' or ',' in an inline table
    key_start, parts, line = -1, 1, 1
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c == "\n":
            line += 1
            if not stack:
                in_key, header, key_start, parts = True, False, -1, 1
            i += 1
        elif c in " \t\r":
            i += 1
        elif c == "#":
            j = text.find("\n", i)
            i = n if j == -1 else j
        elif in_key:
            if c == "[" and not stack and key_start == -1 and not header:  # a table header [a.b] or [[a.b]]
                header = True
                i += 2 if text.startswith("[[", i) else 1
                continue
            if c in "=]" or (c == "}" and stack):
                if c == "]" and not header:  # ']' where a key should be: tomllib reports the syntax
                    return
                in_key, header, key_start, parts = False, False, -1, 1
                if c == "}":
                    stack.pop()
                i += 1
                continue
            if key_start == -1:
                key_start = i
            if c in "\"'":
                j = _string_end(text, i)
                if j == -1:
                    return
                i = j
            elif c == ".":
                parts += 1
                i += 1
            else:
                i += 1
            if parts > MAX_KEY_PARTS:
                raise TomlBoundsError(f"line {line}: a dotted key of more than {MAX_KEY_PARTS} parts: a scene's "
                                      "keys have at most 3 (perturbation.params.mu)")
            if i - key_start > MAX_KEY_CHARS:
                raise TomlBoundsError(f"line {line}: a key longer than {MAX_KEY_CHARS} characters: use short names")
        elif c in "\"'":
            j = _string_end(text, i)
            if j == -1:
                return
            line += text.count("\n", i, j)
            i = j
        elif c in "[{":
            stack.append(c)
            if len(stack) > MAX_DEPTH:
                raise TomlBoundsError(f"line {line}: arrays or inline tables nested more than {MAX_DEPTH} deep: "
                                      "a scene's values nest at most 2 deep ({uniform = [0, 1], seed = 7})")
            if c == "{":
                in_key, key_start, parts = True, -1, 1
            i += 1
        elif c in "]}":
            if stack:
                stack.pop()
            i += 1
        elif c == "," and stack and stack[-1] == "{":
            in_key, key_start, parts = True, -1, 1
            i += 1
        else:  # inside a value: jump to the next character that matters
            match = _VALUE_STOP.search(text, i + 1)
            i = n if match is None else match.start()
