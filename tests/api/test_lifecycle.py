"""Lifecycle and fairness: Location and ETag, retention and orphan cleanup, per-key quotas and rate limits, /metrics."""

from __future__ import annotations

import io
import os
import time
import uuid
from datetime import timedelta

import pytest
import trimesh
from sqlalchemy import update

from api.db import session_scope
from api.jobs.lifecycle import sweep_orphans, sweep_retention, sweep_scratch
from api.jobs.state import now
from api.keys.service import find_active
from api.models import Job
from api.settings import get_settings
from api.storage import get_storage
from tests.api.conftest import BACKENDS, INGEST_ONLY
from tests.meshes import glb_bytes

BOX = glb_bytes(trimesh.creation.box())


def submit(client, auth):
    return client.post("/api/v1/jobs", headers=auth, files={"mesh": ("box.glb", BOX)}, data={"options": INGEST_ONLY})


def set_env(monkeypatch, **values: str) -> None:
    for name, value in values.items():
        monkeypatch.setenv(f"RIGFORGE_{name.upper()}", value)
    get_settings.cache_clear()


def limit_key(auth: dict, **limits: int) -> None:
    with session_scope() as session:
        key = find_active(session, secret=auth["Authorization"].split()[1])
        assert key is not None
        for name, value in limits.items():
            setattr(key, name, value)


def test_202_names_the_job_and_get_answers_304_while_it_is_unchanged(client, auth):
    r = submit(client, auth)
    assert r.status_code == 202 and r.headers["location"] == f"/api/v1/jobs/{r.json()['id']}"
    first = client.get(r.headers["location"], headers=auth)
    etag = first.headers["etag"]
    assert first.status_code == 200 and first.json()["status"] == "succeeded"
    time.sleep(1.1)  # signed download URLs move on with the clock; the job does not
    again = client.get(r.headers["location"], headers={**auth, "If-None-Match": etag})
    assert again.status_code == 304 and again.content == b"" and again.headers["etag"] == etag
    assert client.get(r.headers["location"], headers={**auth, "If-None-Match": '"other"'}).status_code == 200
    rerun = client.post(f"{r.headers['location']}/rerun", headers=auth)
    assert rerun.status_code == 202 and rerun.headers["location"] == f"/api/v1/jobs/{rerun.json()['id']}"


def test_the_etag_changes_with_the_job(client, auth, monkeypatch):
    monkeypatch.setattr("worker.celery_app.enqueue", lambda job_id: None)
    location = submit(client, auth).headers["location"]
    etag = client.get(location, headers=auth).headers["etag"]
    assert client.post(f"{location}/cancel", headers=auth).headers["location"] == location
    changed = client.get(location, headers={**auth, "If-None-Match": etag})
    assert changed.status_code == 200 and changed.json()["status"] == "canceled" and changed.headers["etag"] != etag


def test_retention_deletes_old_finished_jobs_with_their_files(client, auth, data_dir, monkeypatch):
    old, recent = submit(client, auth).json()["id"], client.post(
        "/api/v1/jobs", headers=auth, files={"mesh": ("b.glb", glb_bytes(trimesh.creation.icosphere()))},
        data={"options": INGEST_ONLY}).json()["id"]
    with session_scope() as session:
        session.execute(update(Job).where(Job.id == uuid.UUID(old)).values(finished_at=now() - timedelta(days=8)))
    assert sweep_retention(get_settings()) == 0  # RIGFORGE_RETENTION_DAYS unset: kept forever
    set_env(monkeypatch, retention_days="7")
    assert sweep_retention(get_settings()) == 1
    assert client.get(f"/api/v1/jobs/{old}", headers=auth).status_code == 404
    assert client.get(f"/api/v1/jobs/{recent}", headers=auth).status_code == 200
    storage = data_dir / "storage"
    assert [p.name for p in (storage / "jobs").iterdir()] == [recent] and len(list((storage / "uploads").iterdir())) == 1


def test_the_cleanup_removes_orphaned_uploads_and_outputs_once_old(client, auth, data_dir):
    kept = submit(client, auth).json()["id"]
    storage = data_dir / "storage"
    live = list((storage / "uploads").iterdir())
    stale, fresh = storage / "uploads" / ("a" * 64), storage / "uploads" / ("b" * 64)
    orphan_outputs = storage / "jobs" / str(uuid.uuid4())
    (orphan_outputs / "1").mkdir(parents=True)
    for path in (stale, fresh):
        path.write_bytes(b"left behind by a request that died")
    two_hours_ago = time.time() - 7200
    for path in (stale, orphan_outputs, *live):  # the live job's upload is old too, but an asset names it
        os.utime(path, (two_hours_ago, two_hours_ago))
    assert sweep_orphans(get_settings()) == (1, 1)
    assert not stale.exists() and not orphan_outputs.exists() and fresh.exists()
    assert client.get(f"/api/v1/jobs/{kept}", headers=auth).json()["artifacts"]
    assert len(list((storage / "uploads").iterdir())) == 2


def test_concurrent_jobs_quota_answers_429_with_retry_after(client, auth, other_auth, monkeypatch):
    monkeypatch.setattr("worker.celery_app.enqueue", lambda job_id: None)  # jobs stay queued
    limit_key(auth, max_concurrent_jobs=1)
    assert submit(client, auth).status_code == 202
    r = submit(client, auth)
    assert r.status_code == 429 and r.headers["content-type"] == "application/problem+json"
    assert r.json()["code"] == "quota_concurrent_jobs" and int(r.headers["retry-after"]) > 0
    assert submit(client, other_auth).status_code == 202  # per key


def test_jobs_per_hour_quota_says_when_a_slot_frees(client, auth, monkeypatch):
    set_env(monkeypatch, quotas__jobs_per_hour="2")
    assert submit(client, auth).status_code == 202 and submit(client, auth).status_code == 202
    r = submit(client, auth)
    assert r.status_code == 429 and r.json()["code"] == "quota_jobs_per_hour"
    assert 3500 < int(r.headers["retry-after"]) <= 3600


def test_storage_quota_counts_uploads_and_artifacts(client, auth):
    assert submit(client, auth).status_code == 202
    limit_key(auth, max_storage_bytes=len(BOX) + 100)  # the first job's artifacts already pass it
    r = submit(client, auth)
    assert r.status_code == 429 and r.json()["code"] == "quota_storage" and "delete jobs" in r.json()["detail"]


def test_rate_limit_answers_429_with_retry_after_per_key(client, auth, other_auth, monkeypatch):
    set_env(monkeypatch, rate_limit="5/minute")
    assert all(client.get("/api/v1/jobs", headers=auth).status_code == 200 for _ in range(5))
    r = client.get("/api/v1/jobs", headers=auth)
    assert r.status_code == 429 and r.json()["code"] == "rate_limited" and 0 < int(r.headers["retry-after"]) <= 60
    assert client.get("/api/v1/jobs", headers=other_auth).status_code == 200


def test_metrics_report_jobs_queue_workers_and_stage_durations(client, auth, monkeypatch):
    from worker.maintenance import beat

    assert submit(client, auth).status_code == 202
    monkeypatch.setattr("worker.celery_app.enqueue", lambda job_id: None)
    assert submit(client, auth).status_code == 202
    beat("host:1", concurrency=2)
    text = client.get("/metrics").text
    assert 'rigforge_jobs{status="succeeded"} 1.0' in text and 'rigforge_jobs{status="queued"} 1.0' in text
    assert "rigforge_queue_depth 1.0" in text and "rigforge_workers 1.0" in text and "rigforge_worker_slots 2.0" in text
    assert 'rigforge_stage_duration_seconds_bucket{le="+Inf",stage="ingest"} 1.0' in text


@pytest.mark.parametrize("storage_backend", BACKENDS, indirect=True)
def test_delete_and_the_orphan_sweep_leave_no_stored_file_on_either_backend(client, auth, stored_names, monkeypatch):
    job_id = submit(client, auth).json()["id"]
    assert any("uploads/" in n for n in stored_names()) and any(f"jobs/{job_id}/" in n for n in stored_names())
    assert client.delete(f"/api/v1/jobs/{job_id}", headers=auth).status_code == 204
    assert not [n for n in stored_names() if "uploads/" in n or "jobs/" in n]
    storage = get_storage()
    with storage.stage(io.BytesIO(b"kept by a request that died before its row"), 1000) as staged:
        storage.keep(staged)
    set_env(monkeypatch, orphan_grace_seconds="0.5")
    assert sweep_orphans(get_settings()) == (0, 0)  # too fresh: it may be a request in flight
    time.sleep(1.6)  # past the grace on either backend (S3 times are whole seconds: the sweep allows one more)
    assert sweep_orphans(get_settings()) == (1, 0)
    assert not [n for n in stored_names() if "uploads/" in n]


def test_the_cleanup_removes_scratch_space_a_killed_worker_left(client, data_dir):
    scratch = data_dir / "storage" / "tmp"
    left, live = scratch / "job-3fa85f64-1", scratch / "job-3fa85f64-2"
    for folder in (left, live):
        (folder / "part").mkdir(parents=True)
    long_ago = time.time() - get_settings().jobs.time_limit - get_settings().orphan_grace_seconds - 60
    os.utime(left, (long_ago, long_ago))
    assert sweep_scratch(get_settings()) == 1
    assert not left.exists() and live.exists()
