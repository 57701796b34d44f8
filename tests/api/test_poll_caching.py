"""What the API keeps in memory between requests (verified keys, job views) never outlives a change it was told of;
on the embedded default (no notices from other processes) job polls read the database every time."""

from __future__ import annotations

import uuid

import pytest

from api.db import session_scope
from api.http_cache import GZIP_MIN_BYTES
from api.jobs import state
from api.models import Job
from tests.api.conftest import INGEST_ONLY

TRIANGLE = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"


@pytest.fixture
def lookups(monkeypatch) -> dict[str, int]:
    """Counts database reads of keys and of job views."""
    from api import auth
    from api.jobs import views

    counts = {"keys": 0, "jobs": 0}
    key_lookup, read_view = auth._lookup, views.read_view

    def counted_key(digest: str):  # noqa: ANN202
        counts["keys"] += 1
        return key_lookup(digest)

    def counted_view(job_id: uuid.UUID, base: str):  # noqa: ANN202
        counts["jobs"] += 1
        return read_view(job_id, base)

    monkeypatch.setattr(auth, "_lookup", counted_key)
    monkeypatch.setattr(views, "read_view", counted_view)
    return counts


@pytest.fixture
def admin_auth(client) -> dict:
    from api.keys.service import create_key

    with session_scope() as session:
        return {"Authorization": f"Bearer {create_key(session, name='admin', admin=True)[1]}"}


@pytest.fixture
def queued_job(client, auth, monkeypatch):  # noqa: ANN201
    """Submits jobs that stay queued (nothing runs them)."""
    monkeypatch.setattr("worker.celery_app.enqueue", lambda job_id: None)

    def submit() -> str:
        r = client.post("/api/v1/jobs", headers=auth, files={"mesh": ("box.obj", TRIANGLE)}, data={"options": INGEST_ONLY})
        assert r.status_code == 202, r.text
        return r.json()["id"]

    return submit


def test_a_verified_key_is_looked_up_once_then_kept(client, auth, lookups):
    for _ in range(5):
        assert client.get("/api/v1/keys/me", headers=auth).status_code == 200
    assert lookups["keys"] == 1
    assert client.get("/api/v1/keys/me", headers={"Authorization": "Bearer rf_unknown"}).status_code == 401
    assert client.get("/api/v1/keys/me", headers={"Authorization": "Bearer rf_unknown"}).status_code == 401
    assert lookups["keys"] == 3  # an unknown secret is never kept: a key created meanwhile works at once


def test_a_key_revoked_over_http_stops_working_on_the_next_request(client, auth, admin_auth, lookups):
    me = client.get("/api/v1/keys/me", headers=auth)
    assert me.status_code == 200 and client.get("/api/v1/keys/me", headers=auth).status_code == 200  # now kept
    assert client.post(f"/api/v1/keys/{me.json()['id']}/revoke", headers=admin_auth).status_code == 200
    r = client.get("/api/v1/keys/me", headers=auth)
    assert r.status_code == 401 and r.json()["code"] == "unauthorized"


def test_a_key_revoked_with_the_cli_code_path_stops_working_at_once(client, auth):
    from api.keys.service import revoke

    me = client.get("/api/v1/keys/me", headers=auth).json()
    with session_scope() as session:
        assert revoke(session, key_id_or_prefix=me["prefix"]) is not None
    assert client.get("/api/v1/keys/me", headers=auth).status_code == 401


def test_a_quota_set_after_the_key_was_kept_applies_to_the_next_submit(client, auth, queued_job):
    from api.keys.service import find_active

    queued_job()
    with session_scope() as session:
        key = find_active(session, secret=auth["Authorization"].split()[1])
        assert key is not None
        key.max_concurrent_jobs = 1
    r = client.post("/api/v1/jobs", headers=auth, files={"mesh": ("box.obj", TRIANGLE)})
    assert r.status_code == 429 and r.json()["code"] == "quota_concurrent_jobs"


def test_each_state_change_is_in_the_next_poll_and_its_etag(client, auth, lookups, queued_job):
    job_id = queued_job()
    first = client.get(f"/api/v1/jobs/{job_id}", headers=auth)
    assert first.json()["status"] == "queued"
    assert client.get(f"/api/v1/jobs/{job_id}", headers={**auth, "If-None-Match": first.headers["etag"]}).status_code == 304
    with session_scope() as session:
        claim = state.claim(session, uuid.UUID(job_id), "w1", 60)
        assert claim is not None
    running = client.get(f"/api/v1/jobs/{job_id}", headers={**auth, "If-None-Match": first.headers["etag"]})
    assert running.status_code == 200 and running.json()["status"] == "running"
    with session_scope() as session:
        assert state.report_progress(session, claim, "skeleton", 0.5)
    assert client.get(f"/api/v1/jobs/{job_id}", headers=auth).json()["progress"] == 0.5
    with session_scope() as session:  # a change no notice announces (another process on the embedded default)
        session.get_one(Job, uuid.UUID(job_id)).stage = "skin"
    assert client.get(f"/api/v1/jobs/{job_id}", headers=auth).json()["stage"] == "skin"
    assert lookups["jobs"] == 5  # no notices from other processes here: every poll reads the job


def test_a_canceled_or_deleted_job_is_never_served_from_memory(client, auth, queued_job):
    job_id = queued_job()
    assert client.get(f"/api/v1/jobs/{job_id}", headers=auth).json()["status"] == "queued"
    assert client.post(f"/api/v1/jobs/{job_id}/cancel", headers=auth).status_code == 202
    assert client.get(f"/api/v1/jobs/{job_id}", headers=auth).json()["status"] == "canceled"
    assert client.delete(f"/api/v1/jobs/{job_id}", headers=auth).status_code == 204
    assert client.get(f"/api/v1/jobs/{job_id}", headers=auth).status_code == 404


def test_another_keys_job_is_404_whether_kept_or_not(client, auth, other_auth, queued_job):
    job_id = queued_job()
    for _ in range(2):
        assert client.get(f"/api/v1/jobs/{job_id}", headers=auth).status_code == 200
        r = client.get(f"/api/v1/jobs/{job_id}", headers=other_auth)
        assert r.status_code == 404 and r.json()["code"] == "job_not_found"
        assert client.get(f"/api/v1/jobs/{job_id}/events", headers=other_auth).status_code == 404


def test_a_gzip_client_gets_the_same_json(client, auth, queued_job):
    job_id = queued_job()
    plain = client.get(f"/api/v1/jobs/{job_id}", headers={**auth, "Accept-Encoding": "identity"})
    zipped = client.get(f"/api/v1/jobs/{job_id}", headers={**auth, "Accept-Encoding": "gzip"})
    assert zipped.headers.get("content-encoding") == ("gzip" if len(plain.content) >= GZIP_MIN_BYTES else None)
    assert zipped.json() == plain.json() and zipped.headers["etag"] == plain.headers["etag"]


def test_a_kept_gzip_body_is_sent_only_to_gzip_clients_and_only_when_large():
    import gzip

    from api.http_cache import conditional, gzipped

    big = b'{"x": "' + b"a" * GZIP_MIN_BYTES + b'"}'  # a queued job's JSON is below the threshold: test the path here
    zipped = conditional(big, '"t"', None, "gzip, deflate", lambda: gzipped(big))
    assert zipped.headers["content-encoding"] == "gzip" and zipped.headers["vary"] == "Accept-Encoding"
    assert gzip.decompress(zipped.body) == big
    assert "content-encoding" not in conditional(big, '"t"', None, "identity", lambda: gzipped(big)).headers
    small = b'{"x": 1}'
    assert conditional(small, '"t"', None, "gzip", lambda: gzipped(small)).body == small
    assert conditional(big, '"t"', '"t"', "gzip", lambda: gzipped(big)).status_code == 304
