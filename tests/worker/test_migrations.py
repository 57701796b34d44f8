"""Alembic: upgrade from empty works and the models match the migrations exactly."""

from __future__ import annotations

from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext

from api.db import make_engine
from api.migrate import upgrade_head
from api.models import Base


def assert_no_drift(url: str) -> None:
    upgrade_head(url)
    engine = make_engine(url)
    with engine.connect() as conn:
        diff = compare_metadata(MigrationContext.configure(conn), Base.metadata)
    engine.dispose()
    assert diff == [], diff


def test_sqlite_upgrade_head_from_empty_has_no_drift(tmp_path):
    assert_no_drift(f"sqlite:///{tmp_path / 'fresh.db'}")
