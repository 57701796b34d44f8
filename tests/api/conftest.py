"""API tests: SQLite in a temp dir, jobs executed in-process right after they are enqueued."""

from __future__ import annotations

import socket
from collections.abc import Callable, Iterator

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
def storage_backend(request) -> str:
    """'local' (the default) or 's3'; test modules run on both with
    `pytestmark = pytest.mark.parametrize("storage_backend", BACKENDS, indirect=True)`."""
    return getattr(request, "param", "local")


BACKENDS = ["local", "s3"]


@pytest.fixture
def storage_settings(storage_backend, monkeypatch) -> Iterator[dict[str, str]]:
    """RIGFORGE_ settings of the backend: none for local files, a fresh bucket on the test S3 server for s3."""
    if storage_backend == "local":
        yield {}
        return
    from tests.s3_server import CREDENTIALS, S3_ENDPOINT, drop_bucket, new_bucket

    for name, value in CREDENTIALS.items():
        monkeypatch.setenv(name, value)
    bucket = new_bucket()
    yield {"storage_url": f"s3://{bucket}/rigforge", "s3_endpoint_url": S3_ENDPOINT}
    drop_bucket(bucket)


@pytest.fixture
def stored_names(storage_settings, data_dir) -> Callable[[], list[str]]:
    """Lists every stored name: files under the data directory and, on S3, the bucket's keys."""

    def names() -> list[str]:
        local = [str(p.relative_to(data_dir)) for p in data_dir.rglob("*") if p.is_file()]
        if not storage_settings:
            return local
        from tests.s3_server import bucket_keys

        return local + bucket_keys(storage_settings["storage_url"].split("/")[2])

    return names


@pytest.fixture
def client(data_dir, inline_worker, storage_settings) -> Iterator[TestClient]:
    with service_env(data_dir, max_upload_mb="2", **storage_settings):
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
