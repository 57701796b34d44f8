"""The same code on PostgreSQL + Redis with a real Celery worker process, including a SIGKILL mid-job."""

from __future__ import annotations

import os
import signal

import pytest

from tests.integration.conftest import scaled_service, start_worker, wait_for
from tests.worker.test_migrations import assert_no_drift

pytestmark = pytest.mark.integration
FAST_LEASE = {"jobs__lease_seconds": "3", "jobs__heartbeat_seconds": "0.5", "jobs__reconcile_seconds": "0.5"}


def test_postgres_migrations_have_no_drift(pg_url):
    assert_no_drift(pg_url)


@pytest.fixture
def scaled(tmp_path, pg_url, redis_url):
    """API in-process and env for workers: PostgreSQL database, Redis broker, shared data dir."""
    with scaled_service(tmp_path / "data", pg_url, redis_url, "it", **FAST_LEASE) as service:
        yield service


def job_status(client, job_id):  # noqa: ANN001, ANN201
    return client.get(f"/api/v1/jobs/{job_id}").json()


def test_real_worker_runs_a_job_from_redis(scaled, dev_assets):
    client, env = scaled
    assert client.get("/readyz").json()["checks"] == {"database": "ok", "broker": "ok", "storage": "ok"}
    worker = start_worker(env)
    try:
        r = client.post("/api/v1/jobs", files={"mesh": ("fox.glb", (dev_assets / "fox.glb").read_bytes())}, data={"options": '{"stages": []}'})
        assert r.status_code == 202
        job = wait_for(lambda: (j := job_status(client, r.json()["id"]))["status"] in ("succeeded", "failed") and j, 90)
        assert job["status"] == "succeeded", job
        assert {a["name"] for a in job["artifacts"]} >= {"mesh.glb", "report.json"}
    finally:
        os.killpg(worker.pid, signal.SIGTERM)
        worker.wait(30)


def test_sigkilled_worker_job_is_retried_and_completes_exactly_once(scaled, dev_assets):
    client, env = scaled
    worker = start_worker(env)
    try:
        r = client.post("/api/v1/jobs", files={"mesh": ("xbot.glb", (dev_assets / "xbot.glb").read_bytes())})
        job_id = r.json()["id"]
        wait_for(lambda: job_status(client, job_id)["status"] == "running", 90, 0.05)
        os.killpg(worker.pid, signal.SIGKILL)
        worker.wait(10)
        assert job_status(client, job_id)["status"] == "running"  # nobody has noticed yet
        worker = start_worker(env)
        job = wait_for(lambda: (j := job_status(client, job_id))["status"] in ("succeeded", "failed") and j, 300, 0.5)
        assert job["status"] == "succeeded", job
        assert job["attempts"] == 2
        names = [a["name"] for a in job["artifacts"]]
        assert len(names) == len(set(names)) and "mesh.glb" in names
        assert all(f"/{job_id}/" in a["url"] for a in job["artifacts"])
    finally:
        os.killpg(worker.pid, signal.SIGKILL)
        worker.wait(10)
