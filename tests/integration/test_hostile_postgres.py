"""The hostile-input requests and the idempotency race on PostgreSQL (jobs run inline, no broker needed)."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient

from tests.api.conftest import inline_worker  # noqa: F401 - fixture
from tests.api.test_idempotency_race import race_submits
from tests.hostile.test_hostile_inputs import THROUGH_API, assert_api_outcome
from tests.service_env import service_env

pytestmark = pytest.mark.integration


@pytest.fixture
def pg_client(tmp_path, pg_url, inline_worker):  # noqa: F811
    with service_env(tmp_path / "data", database_url=pg_url, max_upload_mb="2"):
        from api.app import create_app
        from api.db import session_scope
        from api.keys.service import create_key

        with session_scope() as s:
            secret = create_key(s, name="hostile")[1]
        with TestClient(create_app(), raise_server_exceptions=False) as client:
            yield client, {"Authorization": f"Bearer {secret}"}


def test_hostile_requests_on_postgres(pg_client):
    client, auth = pg_client
    for case in THROUGH_API:
        assert_api_outcome(client, auth, case)


def test_idempotency_race_on_postgres(pg_client):
    client, auth = pg_client
    responses = race_submits(client, {**auth, "Idempotency-Key": "pg-race"})
    assert {r.status_code for r in responses} == {202} and len({r.json()["id"] for r in responses}) == 1
