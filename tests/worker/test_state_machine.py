"""The job state machine's compare-and-set transitions and the reconciler's recovery rules."""

from __future__ import annotations

from datetime import timedelta

import pytest

from api.db import session_scope
from api.jobs import state
from api.models import Asset, Job
from tests.service_env import service_env


@pytest.fixture
def job_id(tmp_path):
    with service_env(tmp_path / "data"):
        from api.keys.service import create_key

        with session_scope() as s:
            key, _ = create_key(s, name="k")
            asset = Asset(owner_id=key.id, filename="m.obj", format="obj", size=1, sha256="0" * 64, path="/dev/null")
            s.add(asset)
            s.flush()
            job = Job(owner_id=key.id, mesh_asset_id=asset.id, request_hash="h", options={})
            s.add(job)
        yield job.id


def get(job_id) -> Job:
    with session_scope() as s:
        return s.get_one(Job, job_id)


def test_only_one_claim_wins(job_id):
    with session_scope() as s:
        first = state.claim(s, job_id, "w1", 60)
        second = state.claim(s, job_id, "w2", 60)
    assert first is not None and first.attempt == 1 and second is None
    assert get(job_id).status == "running" and get(job_id).worker_id == "w1"


def test_a_stale_attempt_cannot_finish_or_report(job_id):
    with session_scope() as s:
        old = state.claim(s, job_id, "w1", 60)
        s.get_one(Job, job_id).lease_expires_at = state.now() - timedelta(seconds=1)
        s.commit()
        requeued, lost = state.reconcile(s, max_attempts=3, requeue_after_seconds=60)
        assert requeued == [job_id] and lost == []
        new = state.claim(s, job_id, "w2", 60)
        assert old is not None and new is not None and new.attempt == 2
        assert not state.report_progress(s, old, "skin", 0.5)
        assert not state.succeed(s, old, [])
        assert state.heartbeat(s, old, 60) is None
        assert state.succeed(s, new, [dict(name="report.json", media_type="application/json", size=2, sha256="x", path="/p")])
    job = get(job_id)
    assert job.status == "succeeded" and job.attempts == 2 and [a.name for a in job.artifacts] == ["report.json"]


def test_lost_job_past_max_attempts_fails_as_worker_lost(job_id):
    with session_scope() as s:
        for _ in range(2):
            state.claim(s, job_id, "w", 60)
            s.get_one(Job, job_id).lease_expires_at = state.now() - timedelta(seconds=1)
            s.commit()
            state.reconcile(s, max_attempts=2, requeue_after_seconds=60)
    job = get(job_id)
    assert job.status == "failed" and job.error_code == "worker_lost" and job.attempts == 2


def test_stale_queued_job_is_resent_and_live_lease_is_left_alone(job_id):
    with session_scope() as s:
        s.get_one(Job, job_id).enqueued_at = state.now() - timedelta(seconds=120)
        s.commit()
        assert state.reconcile(s, max_attempts=3, requeue_after_seconds=60) == ([job_id], [])
        assert state.reconcile(s, max_attempts=3, requeue_after_seconds=60) == ([], [])  # just re-sent
        state.claim(s, job_id, "w", 60)
        assert state.reconcile(s, max_attempts=3, requeue_after_seconds=60) == ([], [])


def test_cancel_stops_a_running_attempt(job_id):
    with session_scope() as s:
        c = state.claim(s, job_id, "w", 60)
        assert c is not None
        assert state.cancel(s, job_id)
        assert state.heartbeat(s, c, 60) == "canceled"
        assert not state.succeed(s, c, [])
        assert not state.cancel(s, job_id)
    assert get(job_id).status == "canceled"


def test_a_dead_pool_process_gives_its_job_back_at_once(job_id):
    """release_lost (a worker's main process saw the pool process die): queued again without waiting for the lease,
    only when that process still held the job."""
    with session_scope() as s:
        first = state.claim(s, job_id, "host:101", 60)
        assert first is not None
        assert state.release_lost(s, job_id, "host:999", max_attempts=3) is None  # another process's attempt
        assert get(job_id).status == "running"
        assert state.release_lost(s, job_id, "host:101", max_attempts=3) == "queued"
        assert state.release_lost(s, job_id, "host:101", max_attempts=3) is None  # already given back
        job = get(job_id)
        assert job.status == "queued" and job.worker_id is None and job.lease_expires_at is None
        second = state.claim(s, job_id, "host:102", 60)
        assert second is not None and second.attempt == 2
        assert not state.succeed(s, first, [])  # the dead attempt is fenced off
        assert state.release_lost(s, job_id, "host:102", max_attempts=2) == "failed"
    job = get(job_id)
    assert job.status == "failed" and job.error_code == "worker_lost"


def test_reconcile_announces_only_jobs_whose_state_changed(job_id, monkeypatch):
    published: list[str] = []
    monkeypatch.setattr(state.changes, "publish", lambda kind, ident: published.append(str(ident)))
    with session_scope() as s:
        s.get_one(Job, job_id).enqueued_at = state.now() - timedelta(seconds=120)
        s.commit()
        assert state.reconcile(s, max_attempts=3, requeue_after_seconds=60) == ([job_id], [])
        assert published == []  # only re-sent: what a client sees is unchanged
        claim = state.claim(s, job_id, "w", 60)
        assert claim is not None and published == [str(job_id)]
        s.get_one(Job, job_id).lease_expires_at = state.now() - timedelta(seconds=1)
        s.commit()
        assert state.reconcile(s, max_attempts=3, requeue_after_seconds=60) == ([job_id], [])
        assert published == [str(job_id)] * 2  # lease lost: running -> queued is announced
