"""Bearer-key authentication as a FastAPI dependency."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from api.db import session_scope
from api.errors import Problem
from api.keys.service import find_active
from api.models import ApiKey

# Documents the scheme in OpenAPI (generated clients send the header); this module answers the 401 itself.
bearer = HTTPBearer(auto_error=False, scheme_name="bearerAuth", description="an API key: `Authorization: Bearer <key>`")


def current_key(request: Request, credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(bearer)]) -> ApiKey:
    """The active key named by `Authorization: Bearer <key>`. Keys in URLs are refused: URLs end up in access logs,
    browser history and shared links (downloads have signed links, events are read with the header)."""
    if "key" in request.query_params:
        raise Problem(401, "key_in_url", "send the API key in the 'Authorization: Bearer <key>' header, never in the URL; "
                      "to download without a key use the job's download_url", field="key", headers={"WWW-Authenticate": "Bearer"})
    secret = credentials.credentials if credentials else ""
    if not secret:
        raise Problem(401, "unauthorized", "send an API key as 'Authorization: Bearer <key>'", headers={"WWW-Authenticate": "Bearer"})
    with session_scope() as session:
        key = find_active(session, secret=secret.strip())
    if key is None:
        raise Problem(401, "unauthorized", "the API key is unknown or revoked", headers={"WWW-Authenticate": "Bearer"})
    return key


CurrentKey = Annotated[ApiKey, Depends(current_key)]
