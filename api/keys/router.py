"""/api/v1/keys: who am I (the dashboard's sign-in check), and key management by admin keys.

Listing, creating and revoking keys needs an admin key in every environment: the local key `rigforge serve`
makes on a fresh embedded install, or one made with `rigforge keys create --admin` on the server.
"""

from __future__ import annotations

import uuid
from datetime import datetime
from typing import Annotated

from fastapi import APIRouter, Depends
from pydantic import BaseModel, Field

from api.auth import CurrentKey
from api.db import session_scope
from api.errors import Problem
from api.keys import service
from api.models import ApiKey
from api.problem_schema import problem_responses

router = APIRouter(prefix="/api/v1/keys", tags=["keys"], responses=problem_responses(401, 429))


class KeyOut(BaseModel):
    id: uuid.UUID
    name: str
    prefix: str
    admin: bool = Field(False, description="admin keys manage keys")
    created_at: datetime
    revoked_at: datetime | None = None


class KeyCreate(BaseModel):
    name: str = Field(min_length=1, max_length=200, description="who or what uses this key")
    admin: bool = Field(False, description="let the new key manage keys too")


class KeyCreated(BaseModel):
    key: KeyOut
    secret: str = Field(description="the key itself; shown only in this response")


def to_schema(row: ApiKey) -> KeyOut:
    return KeyOut(id=row.id, name=row.name, prefix=row.prefix, admin=row.is_admin, created_at=row.created_at,
                  revoked_at=row.revoked_at)


def key_admin(key: CurrentKey) -> ApiKey:
    """The signed-in key, when it is an admin key."""
    if not key.is_admin:
        raise Problem(403, "admin_required", "only an admin key manages keys (`rigforge keys create --admin` on the server)")
    return key


KeyAdmin = Annotated[ApiKey, Depends(key_admin)]


@router.get("/me", response_model=KeyOut, summary="The key this request is signed with", operation_id="getCurrentKey")
def whoami(key: CurrentKey) -> KeyOut:
    return to_schema(key)


@router.get("", response_model=list[KeyOut], summary="List every key, oldest first (admin keys only)", responses=problem_responses(403))
def list_keys(_: KeyAdmin) -> list[KeyOut]:
    with session_scope() as session:
        return [to_schema(k) for k in service.list_keys(session)]


@router.post("", status_code=201, response_model=KeyCreated, summary="Create a key (admin keys only)",
             responses=problem_responses(403, 422, examples={422: ("validation_error", "name: String should have at least 1 character", "name")}))
def create_key(body: KeyCreate, _: KeyAdmin) -> KeyCreated:
    with session_scope() as session:
        row, secret = service.create_key(session, name=body.name.strip() or "unnamed", admin=body.admin)
        return KeyCreated(key=to_schema(row), secret=secret)


@router.post("/{key_id}/revoke", response_model=KeyOut, summary="Revoke a key (admin keys only)",
             responses=problem_responses(403, 404, 422, examples={404: ("key_not_found", "no key 3fa85f64-5717-4562-b3fc-2c963f66afa6", None)}))
def revoke_key(key_id: uuid.UUID, _: KeyAdmin) -> KeyOut:
    with session_scope() as session:
        row = service.revoke(session, key_id_or_prefix=str(key_id))
        if row is None:
            raise Problem(404, "key_not_found", f"no key {key_id}")
        return to_schema(row)
