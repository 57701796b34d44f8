"""/api/v1/keys: who am I (sign-in check for the dashboard)."""

from __future__ import annotations

import uuid
from datetime import datetime

from fastapi import APIRouter
from pydantic import BaseModel

from api.auth import CurrentKey

router = APIRouter(prefix="/api/v1/keys", tags=["keys"])


class KeyOut(BaseModel):
    id: uuid.UUID
    name: str
    prefix: str
    created_at: datetime


@router.get("/me", response_model=KeyOut, summary="The key this request is signed with")
def whoami(key: CurrentKey) -> KeyOut:
    return KeyOut(id=key.id, name=key.name, prefix=key.prefix, created_at=key.created_at)
