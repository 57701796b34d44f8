"""The methods an evaluation's `--method` values stand for (shared by `rigforge eval skeleton` and `eval skin`)."""

from __future__ import annotations

from collections.abc import Sequence

from simcore.errors import InvalidInput


def listed_methods(method: str | Sequence[str], known: Sequence[str], every: Sequence[str], what: str) -> list[str]:
    """`method` (one value or several, in order, each once) as methods to run: "all" alone stands for `every`;
    InvalidInput (field `method`) for a name not in `known` or "all" beside others. `what` names the methods in
    the message ("skinning method")."""
    listed = [method] if isinstance(method, str) else list(dict.fromkeys(method))
    for m in listed:
        if m not in (*known, "all") or (m == "all" and len(listed) > 1):
            raise InvalidInput(f"unknown {what} {m!r}; use one of {', '.join(known)}, or all alone",
                               code="invalid_option", field="method")
    return list(every) if listed == ["all"] else listed
