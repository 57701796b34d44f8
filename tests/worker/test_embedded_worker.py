"""The supervised embedded worker on the filesystem:// broker, with real process kills (loopback only, bounded waits)."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
import uuid
from pathlib import Path

import httpx
import pytest

from tests.service_env import service_env

REPO = Path(__file__).resolve().parents[2]
MESH = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
FAST = {"jobs__lease_seconds": "3", "jobs__heartbeat_seconds": "0.5", "jobs__reconcile_seconds": "0.5",
        "jobs__requeue_after_seconds": "5", "jobs__worker_stall_seconds": "10", "jobs__worker_check_seconds": "0.5"}


def processes() -> dict[int, tuple[int, int]]:
    """pid → (parent pid, process group) of every process (from /proc)."""
    out = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            out[int(entry.name)] = (int(fields[1]), int(fields[2]))
    return out


def children(pid: int) -> list[int]:
    return [p for p, (ppid, _) in processes().items() if ppid == pid]


def group(pgid: int) -> list[int]:
    return [p for p, (_, g) in processes().items() if g == pgid]


def wait_for(predicate, timeout: float, interval: float = 0.2):  # noqa: ANN001, ANN201
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if value := predicate():
            return value
        time.sleep(interval)
    raise AssertionError(f"condition not met within {timeout} s")


def submit_jobs(count: int, stages: list | None = None) -> list[uuid.UUID]:
    from api.db import session_scope
    from api.jobs.service import create_job
    from api.keys.service import create_key
    from api.queue import enqueue_job
    from api.storage import get_storage
    from simcore.options import JobOptions

    storage = get_storage()
    ids = []
    with session_scope() as session:
        owner = create_key(session, name="fault")[0].id
    for k in range(count):
        import io

        with storage.stage(io.BytesIO(MESH + f"# job {k}\n".encode()), 10**6) as staged:
            stored = storage.keep(staged)
        with session_scope() as session:
            job, _ = create_job(session, owner_id=owner, mesh=(stored, "t.obj", "obj"), motion=None,
                                options=JobOptions(stages=stages or []), idempotency_key=None)
            ids.append(job.id)
        enqueue_job(ids[-1])
    return ids


def job_rows(ids: list[uuid.UUID]) -> list:
    from api.db import session_scope
    from api.models import Job

    with session_scope() as session:
        return [session.get(Job, i) for i in ids]


def all_finished(ids: list[uuid.UUID]) -> list | None:
    rows = job_rows(ids)
    return rows if all(j.status in ("succeeded", "failed", "canceled") for j in rows) else None


def test_five_pool_kills_in_a_row_and_every_queued_job_still_finishes(tmp_path):
    from api.settings import get_settings
    from worker.embedded import EmbeddedWorker

    with service_env(tmp_path / "data", **FAST):
        worker = EmbeddedWorker(get_settings(), [sys.executable, "-m", "cli.main", "worker", "--loglevel", "WARNING"])
        worker.start()
        try:
            ids = submit_jobs(4)
            killed: list[int] = []
            for _ in range(5):  # what the OOM killer does to the pool process, again and again
                pool = wait_for(lambda: [p for p in children(worker.proc.pid) if p not in killed] if worker.proc else None, 120)
                os.kill(pool[0], signal.SIGKILL)
                killed.append(pool[0])
            ids += submit_jobs(4)
            rows = wait_for(lambda: all_finished(ids), 240, 1)
            assert [j.status for j in rows] == ["succeeded"] * len(ids), [(j.status, j.error_code) for j in rows]
        finally:
            worker.stop(grace=5)
        assert worker.proc is not None and worker.proc.poll() is not None and not group(worker.proc.pid)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def serve(tmp_path):
    """`rigforge serve` on a loopback port with a fast supervisor; yields (process, base url)."""
    port = free_port()
    env = {**os.environ, "RIGFORGE_DATA_DIR": str(tmp_path / "data"), **{f"RIGFORGE_{k.upper()}": v for k, v in FAST.items()}}
    proc = subprocess.Popen([sys.executable, "-m", "cli.main", "serve", "--port", str(port)], cwd=REPO, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        yield proc, f"http://127.0.0.1:{port}"
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)


def readyz(base: str) -> tuple[int, dict]:
    try:
        r = httpx.get(f"{base}/readyz", timeout=5)
    except httpx.TransportError:
        return 0, {}
    return r.status_code, r.json()


def test_serve_restarts_a_dead_worker_reports_it_and_leaves_no_orphan_after_sigterm(serve):
    proc, base = serve
    wait_for(lambda: readyz(base)[0] == 200, 90, 0.5)
    worker_pid = wait_for(lambda: [p for p in children(proc.pid) if group(p) and processes()[p][1] == p], 30)[0]
    os.killpg(worker_pid, signal.SIGKILL)
    status, body = wait_for(lambda: (r := readyz(base))[0] == 503 and r, 30, 0.1)
    assert body["checks"]["worker"].startswith("error"), body
    wait_for(lambda: readyz(base)[0] == 200, 60, 0.5)
    new_worker = [p for p in children(proc.pid) if processes()[p][1] == p]
    assert new_worker and new_worker[0] != worker_pid
    wait_for(lambda: children(new_worker[0]), 30)  # its pool is up
    proc.send_signal(signal.SIGTERM)
    proc.wait(30)
    wait_for(lambda: not group(new_worker[0]), 20)


def test_the_embedded_worker_yields_the_cpu_to_the_api(tmp_path):
    """It runs `worker_nice` below serve (its pool processes inherit that), so requests are answered first."""
    from api.settings import get_settings
    from worker.embedded import EmbeddedWorker

    seen = tmp_path / "nice"
    report = f"import os, pathlib, time; pathlib.Path({str(seen)!r}).write_text(str(os.nice(0))); time.sleep(60)"
    with service_env(tmp_path / "data", jobs__worker_nice="7"):
        worker = EmbeddedWorker(get_settings(), [sys.executable, "-c", report])
        worker.start()
        try:
            wait_for(lambda: seen.exists() and seen.read_text(), 30, 0.1)
        finally:
            worker.stop(grace=1)
    assert int(seen.read_text()) == min(19, os.nice(0) + 7)
