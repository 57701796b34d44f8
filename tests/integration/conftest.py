"""Real PostgreSQL and Redis on 127.0.0.1 (started by .ci/run). In CI an unreachable service fails the
test instead of skipping it, so the integration suite can never silently not run."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from tests.service_env import service_env

PG_ADMIN = "postgresql://postgres@127.0.0.1:5432/postgres"
REDIS_URL = "redis://127.0.0.1:6379/7"
REPO = Path(__file__).resolve().parents[2]


def _unavailable(what: str) -> None:
    message = f"{what} is not reachable on 127.0.0.1 (run scripts/services-up.sh)"
    if os.environ.get("CI"):
        pytest.fail(message)
    pytest.skip(message)


@pytest.fixture(scope="session")
def pg_url() -> Iterator[str]:
    import psycopg

    name = f"rigforge_it_{uuid.uuid4().hex[:8]}"
    try:
        admin = psycopg.connect(PG_ADMIN, autocommit=True, connect_timeout=3)
    except psycopg.OperationalError:
        _unavailable("PostgreSQL")
    admin.execute(f'CREATE DATABASE "{name}"')
    yield f"postgresql+psycopg://postgres@127.0.0.1:5432/{name}"
    admin.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')
    admin.close()


@pytest.fixture
def redis_url() -> str:
    import redis

    client = redis.Redis.from_url(REDIS_URL, socket_connect_timeout=3)
    try:
        client.flushdb()
    except redis.exceptions.ConnectionError:
        _unavailable("Redis")
    return REDIS_URL


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_worker(env: dict) -> subprocess.Popen:
    """A real `rigforge worker` process in its own session (so the whole pool can be SIGKILLed)."""
    return subprocess.Popen([sys.executable, "-m", "cli.main", "worker", "--loglevel", "WARNING"], cwd=REPO,
                            env={**os.environ, **env}, start_new_session=True)


def wait_for(predicate, timeout: float, interval: float = 0.1):  # noqa: ANN001, ANN201
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(interval)
    raise AssertionError(f"condition not met within {timeout} s")


@contextmanager
def scaled_service(data: Path, pg_url: str, redis_url: str, key_name: str, **settings: str
                   ) -> Iterator[tuple[TestClient, dict[str, str]]]:
    """The API in-process on PostgreSQL + Redis with a shared data dir and `settings`: (a TestClient holding a new
    key's bearer header, the RIGFORGE_ environment for worker processes)."""
    with service_env(data, database_url=pg_url, broker_url=redis_url, **settings):
        from api.app import create_app
        from api.db import session_scope
        from api.keys.service import create_key

        with session_scope() as s:
            secret = create_key(s, name=key_name)[1]
        env = {k: v for k, v in os.environ.items() if k.startswith("RIGFORGE_")}
        with TestClient(create_app()) as client:
            client.headers["Authorization"] = f"Bearer {secret}"
            yield client, env
