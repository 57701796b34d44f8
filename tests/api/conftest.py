"""API tests: SQLite in a temp dir, jobs executed in-process right after they are enqueued."""

from __future__ import annotations

import socket
from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient

from tests.service_env import service_env


@pytest.fixture
def data_dir(tmp_path):
    return tmp_path / "data"


@pytest.fixture
def inline_worker(monkeypatch) -> list[str]:
    """Replace the broker with a direct call of the worker's runner; returns the enqueued ids."""
    import uuid

    from api.settings import get_settings
    from worker import runner

    sent: list[str] = []

    def enqueue(job_id: str) -> None:
        sent.append(job_id)
        runner.execute(uuid.UUID(job_id), get_settings(), f"inline@{socket.gethostname()}")

    monkeypatch.setattr("worker.celery_app.enqueue", enqueue)
    return sent


@pytest.fixture
def client(data_dir, inline_worker) -> Iterator[TestClient]:
    with service_env(data_dir, max_upload_mb="2"):
        from api.app import create_app

        with TestClient(create_app(), raise_server_exceptions=False) as c:
            yield c


def _new_key(name: str) -> str:
    from api.db import session_scope
    from api.keys.service import create_key

    with session_scope() as session:
        return create_key(session, name=name)[1]


@pytest.fixture
def auth(client) -> dict:
    return {"Authorization": f"Bearer {_new_key('tester')}"}


@pytest.fixture
def other_auth(client) -> dict:
    return {"Authorization": f"Bearer {_new_key('someone else')}"}


INGEST_ONLY = '{"stages": []}'
