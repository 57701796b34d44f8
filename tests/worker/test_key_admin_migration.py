"""Migration 0003: an existing install's first 'local' key becomes its admin; other keys do not."""

from __future__ import annotations

import uuid

from alembic import command
from sqlalchemy import text

from api.db import make_engine
from api.migrate import alembic_config


def upgrade_with_keys(url: str) -> dict[str, bool]:
    command.upgrade(alembic_config(url), "0002")
    engine = make_engine(url)
    with engine.begin() as conn:
        for name, created in (("ci", "2026-01-01"), ("local", "2026-01-02"), ("local", "2026-01-03")):
            conn.execute(text("INSERT INTO api_keys (id, name, prefix, key_hash, created_at) VALUES (:id, :name, 'rf_x', :h, :c)"),
                         {"id": uuid.uuid4().hex, "name": name, "h": uuid.uuid4().hex, "c": created})
    command.upgrade(alembic_config(url), "head")
    with engine.connect() as conn:
        rows = conn.execute(text("SELECT name, created_at, is_admin FROM api_keys ORDER BY created_at")).all()
    engine.dispose()
    return {f"{name}@{str(created)[:10]}": bool(admin) for name, created, admin in rows}


def test_the_first_local_key_becomes_admin_on_upgrade(tmp_path):
    assert upgrade_with_keys(f"sqlite:///{tmp_path / 'old.db'}") == {
        "ci@2026-01-01": False, "local@2026-01-02": True, "local@2026-01-03": False}
