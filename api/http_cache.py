"""Conditional GET: an ETag over the response body and 304 Not Modified on a matching If-None-Match."""

from __future__ import annotations

import hashlib
from typing import Any

from fastapi import Response
from pydantic import BaseModel


def _tags(header: str) -> set[str]:
    return {tag.strip().removeprefix("W/") for tag in header.split(",") if tag.strip()}


def etagged(model: BaseModel, if_none_match: str | None, exclude: Any = None) -> Response:
    """`model` as JSON with its ETag, or an empty 304 when `if_none_match` names it.

    With `exclude` (fields that change without the resource changing, as signed URLs do) the tag covers the rest
    and is weak (`W/`): equal tags mean equivalent answers, not identical bytes.
    """
    body = model.model_dump_json().encode()
    tagged = model.model_dump_json(exclude=exclude).encode() if exclude else body
    etag = ("W/" if exclude else "") + '"' + hashlib.sha256(tagged).hexdigest()[:32] + '"'
    headers = {"ETag": etag, "Cache-Control": "no-cache"}  # no-cache: revalidate every time, which the 304 makes cheap
    if if_none_match is not None and ({"*", etag.removeprefix("W/")} & _tags(if_none_match)):
        return Response(status_code=304, headers=headers)
    return Response(body, media_type="application/json", headers=headers)
