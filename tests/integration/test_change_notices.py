"""On PostgreSQL + Redis, change notices travel between processes: job polls are answered from memory until another
process changes the job, revocations reach the API at once, and idle event streams read nothing."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
import uuid

import pytest

from tests.integration.conftest import REPO, scaled_service, wait_for

pytestmark = pytest.mark.integration
TRIANGLE = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"


@pytest.fixture
def scaled(tmp_path, pg_url, redis_url, monkeypatch):
    """API in-process on PostgreSQL + Redis; jobs stay queued (no worker) until a test moves them."""
    monkeypatch.setattr("worker.celery_app.enqueue", lambda job_id: None)
    with scaled_service(tmp_path / "data", pg_url, redis_url, "notices",  # long lives: only a notice can end them
                        job_cache_seconds="600", auth_cache_seconds="600") as service:
        yield service


def in_another_process(env: dict[str, str], code: str) -> None:
    """Run `code` (with session_scope, state, uuid imported) in a fresh Python process on the same services."""
    prelude = "import uuid, time\nfrom api.db import session_scope\nfrom api.jobs import state\n"
    subprocess.run([sys.executable, "-c", prelude + code], cwd=REPO, env={**os.environ, **env}, check=True, timeout=120)


def submit(client) -> str:  # noqa: ANN001
    r = client.post("/api/v1/jobs", files={"mesh": ("box.obj", TRIANGLE)}, data={"options": '{"stages": []}'})
    assert r.status_code == 202, r.text
    return r.json()["id"]


def notices_live(client) -> None:  # noqa: ANN001
    from api import changes

    client.get("/api/v1/keys/me")  # the first authenticated request subscribes
    wait_for(changes.notices().live, 10, 0.05)


@pytest.fixture
def view_reads(monkeypatch) -> list[str]:
    from api.jobs import views

    reads: list[str] = []
    read_view = views.read_view

    def counted(job_id: uuid.UUID, base: str):  # noqa: ANN202
        reads.append(str(job_id))
        return read_view(job_id, base)

    monkeypatch.setattr(views, "read_view", counted)
    return reads


def test_polls_read_the_job_once_per_change_made_in_any_process(scaled, view_reads):
    client, env = scaled
    notices_live(client)
    job_id = submit(client)
    for _ in range(10):
        assert client.get(f"/api/v1/jobs/{job_id}").json()["status"] == "queued"
    assert len(view_reads) == 1
    in_another_process(env, f"with session_scope() as s:\n    assert state.claim(s, uuid.UUID('{job_id}'), 'elsewhere:1', 60)")
    job = wait_for(lambda: (j := client.get(f"/api/v1/jobs/{job_id}").json())["status"] == "running" and j, 2, 0.01)
    assert job["attempts"] == 1 and len(view_reads) == 2


def test_a_key_revoked_in_another_process_stops_working_at_once(scaled):
    client, env = scaled
    notices_live(client)
    me = client.get("/api/v1/keys/me").json()
    in_another_process(env, f"from api.keys.service import revoke\nwith session_scope() as s:\n"
                            f"    assert revoke(s, key_id_or_prefix='{me['id']}')")
    wait_for(lambda: client.get("/api/v1/keys/me").status_code == 401, 1, 0.01)


def test_event_streams_follow_another_process_without_reading_the_database_between_changes(scaled, monkeypatch):
    from api.jobs import events

    client, env = scaled
    notices_live(client)
    watcher_reads: list[int] = []
    read_moments = events.read_moments

    def counted(ids: list[uuid.UUID]) -> dict:
        watcher_reads.append(len(ids))
        return read_moments(ids)

    monkeypatch.setattr(events, "read_moments", counted)
    job_id = submit(client)
    script = (f"job = uuid.UUID('{job_id}')\ntime.sleep(1.5)\nwith session_scope() as s:\n"
              "    claim = state.claim(s, job, 'elsewhere:2', 60)\n    time.sleep(0.5)\n"
              "    state.report_progress(s, claim, 'ingest', 0.5)\n    time.sleep(0.5)\n    state.succeed(s, claim, [])\n")
    mover = threading.Thread(target=in_another_process, args=(env, script))
    mover.start()
    started = time.monotonic()
    with client.stream("GET", f"/api/v1/jobs/{job_id}/events") as r:
        assert r.status_code == 200
        seen = [json.loads(line[6:]) for line in r.iter_lines() if line.startswith("data: ")]
    mover.join()
    statuses = [e["status"] for e in seen]
    assert statuses[0] == "queued" and "running" in statuses and statuses[-1] == "succeeded" and seen[-1]["progress"] == 1.0
    assert time.monotonic() - started < 10  # notices, not the 15 s keep-alive re-read, moved the stream
    assert watcher_reads == []  # no database watcher while Redis notices are live
