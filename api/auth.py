"""Bearer-key authentication and the per-key rate limit as one FastAPI dependency, with verified keys cached in
this process.

A key is looked up by the SHA-256 of its secret. A verified key is kept for `auth_cache_seconds` (only keys that
exist and are active: an unknown secret is looked up every time, so a new key works at once). Revoking a key
publishes a change notice (api.changes) that empties the cache of this process at once, and of every API process
on a Redis broker; a revocation made in another process without Redis (the CLI on the embedded default) takes
effect within `auth_cache_seconds`.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request
from fastapi.concurrency import run_in_threadpool
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from api import changes, ratelimit
from api.db import session_scope
from api.errors import Problem
from api.keys.service import find_active_by_hash, hash_key
from api.models import ApiKey
from api.notice_cache import NoticeCache
from api.settings import get_settings

# Documents the scheme in OpenAPI (generated clients send the header); this module answers the 401 itself.
bearer = HTTPBearer(auto_error=False, scheme_name="bearerAuth", description="an API key: `Authorization: Bearer <key>`")


_keys: NoticeCache[str, ApiKey] = NoticeCache(0)
changes.listen(lambda kind, _ident: _keys.clear() if kind in ("key", "reset") else None)  # a revocation, or a reset


def key_cache() -> NoticeCache[str, ApiKey]:
    """Verified keys by secret hash, with the configured time-to-live."""
    _keys.ttl = get_settings().auth_cache_seconds
    return _keys


def _lookup(digest: str) -> ApiKey | None:
    with session_scope() as session:
        return find_active_by_hash(session, digest)


async def verified_key(secret: str) -> ApiKey | None:
    """The active key whose secret this is: from the cache, else from the database (then cached)."""
    changes.notices().start()  # on Redis: hear other processes' revocations before trusting the cache
    cache, digest = key_cache(), hash_key(secret)
    key = cache.get(digest)
    if key is None:
        token = cache.token()
        key = await run_in_threadpool(_lookup, digest)
        if key is not None:
            cache.put(digest, key, token)
    return key


async def current_key(request: Request, credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(bearer)]) -> ApiKey:
    """The active key named by `Authorization: Bearer <key>`, its request counted against its rate limit (429 past it).
    Keys in URLs are refused: URLs end up in access logs, browser history and shared links (downloads have signed links,
    events are read with the header). Every /api/v1 route but signed downloads takes it. One dependency for both: FastAPI
    solves a dependency's own dependencies before it looks in its per-request cache, so a rate-limit dependency on
    this one would solve its bearer scheme twice per request."""
    if "key" in request.query_params:
        raise Problem(401, "key_in_url", "send the API key in the 'Authorization: Bearer <key>' header, never in the URL; "
                      "to download without a key use the job's download_url", field="key", headers={"WWW-Authenticate": "Bearer"})
    secret = credentials.credentials if credentials else ""
    if not secret:
        raise Problem(401, "unauthorized", "send an API key as 'Authorization: Bearer <key>'", headers={"WWW-Authenticate": "Bearer"})
    key = await verified_key(secret.strip())
    if key is None:
        raise Problem(401, "unauthorized", "the API key is unknown or revoked", headers={"WWW-Authenticate": "Bearer"})
    await ratelimit.count(key)
    return key


CurrentKey = Annotated[ApiKey, Depends(current_key)]
