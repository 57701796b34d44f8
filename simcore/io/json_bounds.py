"""JSON parsing with a nesting cap: deeply nested input fails as a clear error, never a RecursionError."""

from __future__ import annotations

import json
from typing import Any


class JsonTooDeep(ValueError):
    """The document nests arrays/objects deeper than allowed."""


def json_depth(tree: Any, stop_after: int) -> int:
    """Deepest nesting of arrays/objects in a parsed JSON value, counted up to `stop_after` + 1 (iterative)."""
    deepest, stack = 0, [(tree, 1)]
    while stack:
        value, depth = stack.pop()
        if isinstance(value, dict):
            value = list(value.values())
        if isinstance(value, list):
            deepest = max(deepest, depth)
            if depth > stop_after:
                return depth
            stack.extend((v, depth + 1) for v in value if isinstance(v, (list, dict)))
    return deepest


def loads_bounded(raw: str | bytes, max_depth: int) -> Any:
    """json.loads, raising JsonTooDeep past `max_depth` levels (and json.JSONDecodeError as usual)."""
    try:
        value = json.loads(raw)
    except RecursionError:
        raise JsonTooDeep(f"nested more than {max_depth} levels deep") from None
    if json_depth(value, max_depth) > max_depth:
        raise JsonTooDeep(f"nested more than {max_depth} levels deep")
    return value
