"""Webhooks delivered by a real worker on PostgreSQL + Redis: a receiver that is down while the worker is killed and
replaced gets the event once it is back (the outbox lives in the database); the worker logs JSON with job ids."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys

import pytest
import trimesh

from tests.integration.conftest import REPO, wait_for
from tests.integration.test_postgres_redis import scaled  # noqa: F401 - fixture
from tests.meshes import glb_bytes
from tests.webhook_receiver import free_port, receiver

pytestmark = pytest.mark.integration
FAST_RETRY = {"RIGFORGE_WEBHOOKS__BACKOFF_SECONDS": "0.5", "RIGFORGE_WEBHOOKS__POLL_SECONDS": "0.2", "RIGFORGE_LOG_FORMAT": "json"}


def worker(env: dict, log) -> subprocess.Popen:  # noqa: ANN001
    return subprocess.Popen([sys.executable, "-m", "cli.main", "worker", "--loglevel", "INFO"], cwd=REPO,
                            env={**os.environ, **env, **FAST_RETRY}, start_new_session=True, stdout=log, stderr=log)


def stop(proc: subprocess.Popen, sig: int) -> None:
    os.killpg(proc.pid, sig)
    proc.wait(30)


def test_an_event_outlives_a_killed_worker_and_a_receiver_that_was_down(scaled, tmp_path):  # noqa: F811
    client, env = scaled
    port = free_port()
    log_path = tmp_path / "worker.log"
    with log_path.open("wb") as log:
        first = worker(env, log)
        try:
            r = client.post("/api/v1/jobs", files={"mesh": ("box.glb", glb_bytes(trimesh.creation.box()))},
                            data={"options": '{"stages": []}', "callback_url": f"http://127.0.0.1:{port}/hook"})
            job_id = r.json()["id"]
            failed_once = wait_for(lambda: (j := client.get(f"/api/v1/jobs/{job_id}").json())["webhooks"]
                                   and j["webhooks"][0]["attempts"] and j, 90)
            assert failed_once["status"] == "succeeded" and failed_once["webhooks"][0]["attempts"][0]["status_code"] is None
            wait_for(lambda: "rigforge_workers 1.0" in client.get("/metrics").text, 30)
        finally:
            stop(first, signal.SIGKILL)
        with receiver(port) as hook:
            second = worker(env, log)
            try:
                wait_for(lambda: hook.received, 60)
                log_entry = wait_for(lambda: (d := client.get(f"/api/v1/jobs/{job_id}").json()["webhooks"][0])["status"]
                                     == "delivered" and d, 30)
            finally:
                stop(second, signal.SIGTERM)
    assert json.loads(hook.received[0][1])["data"]["id"] == job_id
    assert log_entry["attempts"][-1]["status_code"] == 200 and len(log_entry["attempts"]) >= 2
    records = [json.loads(line) for line in log_path.read_text().splitlines() if line.startswith("{")]
    assert any(r.get("job_id") == job_id and r["logger"] == "rigforge.webhooks" for r in records), records[-5:]
