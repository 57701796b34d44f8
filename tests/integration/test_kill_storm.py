"""PostgreSQL + Redis with two real workers under repeated SIGKILLs: every job finishes, exactly once.

Most kills hit a pool process in the middle of a job (what the kernel's OOM killer does); every fourth kills a
whole worker, which is then started again. Slow: it runs 30 jobs through 20 kills.
"""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from tests.integration.conftest import scaled_service, start_worker, wait_for
from tests.integration.test_postgres_redis import FAST_LEASE, job_status
from tests.worker.test_embedded_worker import children

pytestmark = [pytest.mark.integration, pytest.mark.slow]
JOBS, KILLS = 30, 20
STORM = {**FAST_LEASE, "jobs__max_attempts": "50", "jobs__requeue_after_seconds": "5",  # lost jobs come back
         "quotas__concurrent_jobs": "0"}  # all 30 jobs queued at once from one key


@pytest.fixture
def storm(tmp_path, pg_url, redis_url):
    """API in-process and the workers' environment: PostgreSQL, Redis, a shared data dir, the storm's settings."""
    with scaled_service(tmp_path / "data", pg_url, redis_url, "storm", **STORM) as service:
        yield service


def finished(client: TestClient, ids: list[str]) -> list[dict] | None:
    """Every job's JSON once none is queued or running."""
    jobs = [job_status(client, i) for i in ids]
    return jobs if all(j["status"] in ("succeeded", "failed", "canceled") for j in jobs) else None


def running_pool_processes(workers: list[subprocess.Popen]) -> list[int]:
    return [pid for w in workers if w.poll() is None for pid in children(w.pid)]


def test_twenty_kills_lose_no_job_and_run_none_twice_to_success(storm, dev_assets):
    client, env = storm
    mesh = (dev_assets / "fox.glb").read_bytes()
    workers = [start_worker(env), start_worker(env)]
    started = time.monotonic()
    try:
        ids = []
        for k in range(JOBS):
            r = client.post("/api/v1/jobs", files={"mesh": (f"fox{k}.glb", mesh)}, data={"options": '{"stages": []}'})
            assert r.status_code == 202, r.text
            ids.append(r.json()["id"])
        kills = 0
        while kills < KILLS:
            wait_for(lambda: any(job_status(client, i)["status"] == "running" for i in ids), 120, 0.05)
            if kills % 4 == 3:  # a whole worker: its jobs come back through the lease and the reconciler
                victim = workers.pop(kills % len(workers))
                os.killpg(victim.pid, signal.SIGKILL)
                victim.wait(10)
                workers.append(start_worker(env))
            else:
                pool = wait_for(lambda: running_pool_processes(workers), 60, 0.05)
                os.kill(pool[kills % len(pool)], signal.SIGKILL)
            kills += 1
            time.sleep(0.5)
        jobs = wait_for(lambda: finished(client, ids), 600, 1)
    finally:
        for w in workers:
            os.killpg(w.pid, signal.SIGKILL)
            w.wait(10)
    assert [j["status"] for j in jobs] == ["succeeded"] * JOBS, [(j["status"], j["error"]) for j in jobs]
    retried = sum(j["attempts"] > 1 for j in jobs)
    storage = Path(env["RIGFORGE_DATA_DIR"]) / "storage" / "jobs"
    for job in jobs:
        published = [p.name for p in (storage / job["id"]).iterdir()]
        assert published == [str(job["attempts"])], (job["id"], published)  # one attempt ran to its outputs
        assert all(f"/{job['id']}/" in a["url"] for a in job["artifacts"])
    print(f"\n{JOBS} jobs, {KILLS} kills, {retried} jobs retried, {time.monotonic() - started:.0f} s")  # noqa: T201 - the figures
