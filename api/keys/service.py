"""API keys: random secrets shown once, stored only as SHA-256 hashes."""

from __future__ import annotations

import hashlib
import secrets
import uuid

from sqlalchemy import select
from sqlalchemy.orm import Session

from api import changes
from api.jobs.state import now
from api.models import ApiKey
from api.webhooks.signing import new_secret

KEY_PREFIX = "rf_"


def hash_key(secret: str) -> str:
    return hashlib.sha256(secret.encode()).hexdigest()


def create_key(session: Session, *, name: str, admin: bool = False) -> tuple[ApiKey, str]:
    """A new key row and its secret (the only time the secret exists outside the client); admin keys manage keys."""
    secret = KEY_PREFIX + secrets.token_urlsafe(32)
    row = ApiKey(name=name, prefix=secret[:10], key_hash=hash_key(secret), is_admin=admin, webhook_secret=new_secret())
    session.add(row)
    session.commit()
    return row, secret


def find_active(session: Session, *, secret: str) -> ApiKey | None:
    return find_active_by_hash(session, hash_key(secret))


def find_active_by_hash(session: Session, digest: str) -> ApiKey | None:
    """The active key whose secret hashes to `digest`, or None (unknown or revoked)."""
    row = session.scalar(select(ApiKey).where(ApiKey.key_hash == digest))
    return row if row is not None and row.revoked_at is None else None


def list_keys(session: Session) -> list[ApiKey]:
    return list(session.scalars(select(ApiKey).order_by(ApiKey.created_at)))


def revoke(session: Session, *, key_id_or_prefix: str) -> ApiKey | None:
    """Revoke by id or by the printed prefix; None when nothing matches."""
    try:
        row = session.get(ApiKey, uuid.UUID(key_id_or_prefix))
    except ValueError:
        row = session.scalar(select(ApiKey).where(ApiKey.prefix == key_id_or_prefix))
    if row is not None and row.revoked_at is None:
        row.revoked_at = now()
        session.commit()
        changes.publish("key", row.id)  # API processes forget the key they verified (api.auth)
    return row
