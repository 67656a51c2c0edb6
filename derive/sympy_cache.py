"""Time-bounded sympy computations (derive/timebox.py) whose outcome is cached on disk (derive/cache.py).

A result found is stored as sympy's ``srepr`` text and read back by :func:`from_srepr`, which walks the
parsed syntax tree and builds only sympy classes from literal arguments (never eval). A time-out (or an
error) is stored too, under a key that names the bound it failed under: a warm call with the same bound
does not spend it again, a larger bound tries again.
"""

from __future__ import annotations

import ast
from typing import Any, Callable

import sympy

from . import cache
from .expression.names import UserSymbol
from .timebox import bounded

NAMESPACE = "sympy-bounded"


def bounded_cached(what: str, key: str, func: Callable, args: tuple, seconds: float):
    """``bounded(func, args, seconds)``, its outcome cached under ``what``/``key`` (``key`` must name
    everything the result depends on: the integrand, the variable). None on time-out or error."""
    if seconds <= 0:
        return None
    base = f"{what}|{key}|sympy {sympy.__version__}"
    found = cache.load(NAMESPACE, base + "|found", _check_found)
    if found is not None:
        try:
            return from_srepr(found["srepr"])
        except ValueError as exc:
            cache.note_damaged(NAMESPACE, base + "|found", str(exc)[:80])
    failed_key = f"{base}|failed within {float(seconds)!r} s"
    if cache.load(NAMESPACE, failed_key, _check_failed) is not None:
        return None
    result = bounded(func, args, seconds)
    if result is None:
        cache.store(NAMESPACE, failed_key, {"seconds": float(seconds)})
        return None
    text = sympy.srepr(result)
    try:
        same = from_srepr(text) == result
    except ValueError:
        same = False
    if same:  # stored only when it reads back identical
        cache.store(NAMESPACE, base + "|found", {"srepr": text})
    return result


def _check_found(value: Any) -> str | None:
    ok = isinstance(value, dict) and isinstance(value.get("srepr"), str)
    return None if ok else "not an {'srepr': text} entry"


def _check_failed(value: Any) -> str | None:
    ok = isinstance(value, dict) and cache.finite_number(value.get("seconds"))
    return None if ok else "not a {'seconds': number} entry"


#: Names srepr may use besides sympy's own classes.
_EXTRA = {"UserSymbol": UserSymbol}


def _constructor(name: str):
    if name in _EXTRA:
        return _EXTRA[name]
    obj = getattr(sympy, name, None)
    if isinstance(obj, type) and issubclass(obj, sympy.Basic):
        return obj
    raise ValueError(f"{name!r} is not a sympy class")


def _build(node: ast.AST):
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float, str, bool, type(None))):
        return node.value
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub) and isinstance(node.operand, ast.Constant):
        return -_build(node.operand)
    if isinstance(node, (ast.Tuple, ast.List)):
        items = [_build(x) for x in node.elts]
        return tuple(items) if isinstance(node, ast.Tuple) else items
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
        cls = _constructor(node.func.id)
        kwargs = {}
        for kw in node.keywords:
            if kw.arg is None:
                raise ValueError("** arguments are not allowed")
            kwargs[kw.arg] = _build(kw.value)
        return cls(*(_build(a) for a in node.args), **kwargs)
    raise ValueError(f"unexpected {type(node).__name__} in srepr text")


def from_srepr(text: str) -> sympy.Basic:
    """The sympy object of ``sympy.srepr`` text; only sympy classes applied to literals (ValueError else)."""
    try:
        tree = ast.parse(text, mode="eval")
        return _build(tree.body)
    except (SyntaxError, TypeError, RecursionError) as exc:
        raise ValueError(f"not srepr text: {type(exc).__name__}") from None
