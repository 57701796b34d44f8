"""Conditional GET: an ETag over the response body and 304 Not Modified on a matching If-None-Match."""

from __future__ import annotations

import gzip
import hashlib
from collections.abc import Callable
from typing import Any

from fastapi import Response
from pydantic import BaseModel


def _tags(header: str) -> set[str]:
    return {tag.strip().removeprefix("W/") for tag in header.split(",") if tag.strip()}


def entity_tag(model: BaseModel, exclude: Any = None) -> tuple[bytes, str]:
    """`model` as JSON bytes and its ETag.

    With `exclude` (fields that change without the resource changing, as signed URLs do) the tag covers the rest
    and is weak (`W/`): equal tags mean equivalent answers, not identical bytes.
    """
    body = model.model_dump_json().encode()
    tagged = model.model_dump_json(exclude=exclude).encode() if exclude else body
    return body, ("W/" if exclude else "") + '"' + hashlib.sha256(tagged).hexdigest()[:32] + '"'


GZIP_MIN_BYTES = 1024  # smaller answers are sent as they are (the app's GZipMiddleware threshold too)


def gzipped(body: bytes) -> bytes:
    """`body` compressed as GZipMiddleware would (an answer kept in memory is compressed once, not per request)."""
    return gzip.compress(body, compresslevel=9, mtime=0)


def conditional(body: bytes, etag: str, if_none_match: str | None, accept_encoding: str | None = None,
                body_gzip: Callable[[], bytes] | None = None) -> Response:
    """`body` (JSON) with its ETag, or an empty 304 when `if_none_match` names it; `body_gzip()` (its gzip form, asked for
    only when sent) goes as it is to clients that accept gzip (GZipMiddleware leaves an answer that has a Content-Encoding
    alone)."""
    headers = {"ETag": etag, "Cache-Control": "no-cache"}  # no-cache: revalidate every time, which the 304 makes cheap
    if if_none_match is not None and ({"*", etag.removeprefix("W/")} & _tags(if_none_match)):
        return Response(status_code=304, headers=headers)
    if body_gzip is not None and "gzip" in (accept_encoding or "") and len(body) >= GZIP_MIN_BYTES:
        return Response(body_gzip(), media_type="application/json", headers={**headers, "Content-Encoding": "gzip",
                                                                           "Vary": "Accept-Encoding"})
    return Response(body, media_type="application/json", headers=headers)


def etagged(model: BaseModel, if_none_match: str | None, exclude: Any = None) -> Response:
    """`model` as JSON with its ETag, or an empty 304 when `if_none_match` names it."""
    return conditional(*entity_tag(model, exclude), if_none_match)
