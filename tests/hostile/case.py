"""One hostile input and the outcomes it may have."""

from __future__ import annotations

from dataclasses import dataclass, field

OK = "ok"  # the input is odd but valid: the job runs


@dataclass(frozen=True)
class Case:
    """A hostile input. kind: mesh | motion (a file), options (the form field's text), request (a whole request).

    expect: the acceptable outcome codes (a problem's or a failed job's `code`, or OK); never internal_error.
    """

    name: str
    kind: str
    data: bytes = b""
    expect: frozenset[str] = frozenset()
    request: dict = field(default_factory=dict)  # kind == "request": files [(field, filename, bytes)], form, headers


def case(name: str, kind: str, data: bytes | str, *codes: str, **request: object) -> Case:
    raw = data.encode() if isinstance(data, str) else data
    return Case(name, kind, raw, frozenset(codes), dict(request))
