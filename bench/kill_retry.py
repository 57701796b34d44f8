"""Kill → retry: seconds from a SIGKILL in the middle of a job to the start of its next attempt, on PostgreSQL + Redis
with two real workers and the default lease, heartbeat and reconciler settings.

Two kinds of kill alternate: the pool process running the job (what the kernel's OOM killer does; its worker's main
process re-queues the job at once) and the whole worker, main process included (only the lease and another
worker's reconciler can bring the job back; a fresh worker replaces it). One full-pipeline job runs at a time, so a
free worker is always there to take the retry; after each retry starts the job is canceled. The start of an attempt
is the job row's `started_at`, read back from the database. Prints a table and writes bench/results/kill_retry.json.

    .venv/bin/python bench/kill_retry.py [--kills 8]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from datetime import datetime
from pathlib import Path

import httpx
import psycopg
import trimesh
from load import DEV, REPO, UNLIMITED, free_port, glb, postgres_and_redis  # bench/load.py, beside this script

DEADLINE_SECONDS = 120


def start_worker(env: dict[str, str]) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "cli.main", "worker", "--loglevel", "WARNING"], cwd=REPO, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)


def row(db: psycopg.Connection, job_id: str) -> tuple[str, int, str | None, datetime | None]:
    """(status, attempts, worker_id, started_at) of the job."""
    found = db.execute("SELECT status, attempts, worker_id, started_at FROM jobs WHERE id = %s", (job_id,)).fetchone()
    assert found is not None
    return found[0], found[1], found[2], found[3]


def wait_row(db: psycopg.Connection, job_id: str, done, what: str) -> tuple[str, int, str | None, datetime | None]:  # noqa: ANN001
    deadline = time.monotonic() + DEADLINE_SECONDS
    while time.monotonic() < deadline:
        found = row(db, job_id)
        if done(found):
            return found
        time.sleep(0.05)
    raise RuntimeError(f"job {job_id}: {what} did not happen within {DEADLINE_SECONDS} s")


def ready(base: str, data: Path) -> bool:
    try:
        return (data / "local-api-key").exists() and httpx.get(f"{base}/readyz", timeout=5).status_code == 200
    except httpx.HTTPError:
        return False


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--kills", type=int, default=8, help="kills, alternating pool process and whole worker")
    args = parser.parse_args()
    mesh = (DEV / "fox.glb").read_bytes() if (DEV / "fox.glb").exists() else glb(trimesh.creation.box())
    load_before = os.getloadavg()[0]
    results: list[dict] = []
    with postgres_and_redis() as service, tempfile.TemporaryDirectory(prefix="rigforge-kill-") as tmp:
        env = {**os.environ, **UNLIMITED, **service, "RIGFORGE_DATA_DIR": tmp, "RIGFORGE_ENV": "development"}
        port = free_port()
        api = subprocess.Popen([sys.executable, "-m", "cli.main", "serve", "--no-worker", "--port", str(port)], cwd=REPO, env=env,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        workers = [start_worker(env), start_worker(env)]
        db = psycopg.connect(service["RIGFORGE_DATABASE_URL"].replace("+psycopg", ""), autocommit=True)
        base = f"http://127.0.0.1:{port}"
        try:
            deadline = time.monotonic() + 180
            while not ready(base, Path(tmp)):
                if time.monotonic() > deadline or api.poll() is not None:
                    raise RuntimeError("rigforge serve did not become ready in 180 s")
                time.sleep(0.5)
            headers = {"Authorization": f"Bearer {(Path(tmp) / 'local-api-key').read_text().strip()}"}
            for k in range(args.kills):
                kind = "pool process" if k % 2 == 0 else "whole worker"
                job_id = httpx.post(f"{base}/api/v1/jobs", headers=headers, files={"mesh": ("fox.glb", mesh)}, timeout=60).json()["id"]
                _, attempt, worker_id, _ = wait_row(db, job_id, lambda r: r[0] == "running", "a first run")
                time.sleep(1.0)  # mid-job
                pid = int(str(worker_id).rsplit(":", 1)[1])
                if kind == "pool process":
                    killed_at = time.time()
                    os.kill(pid, signal.SIGKILL)
                else:
                    victim = next(w for w in workers if pid == w.pid or str(pid) in subprocess.run(
                        ["pgrep", "-g", str(w.pid)], capture_output=True, text=True).stdout.split())
                    killed_at = time.time()
                    os.killpg(victim.pid, signal.SIGKILL)
                    victim.wait(10)
                    workers.remove(victim)
                    workers.append(start_worker(env))
                status, attempts, _, started = wait_row(db, job_id, lambda r, a=attempt: r[1] > a and r[0] in ("running", "succeeded"),
                                                        "a retry")
                assert started is not None
                seconds = started.timestamp() - killed_at
                results.append({"kind": kind, "seconds": round(seconds, 2), "attempt": attempts})
                print(f"kill {k + 1}/{args.kills} ({kind}): retry started {seconds:.1f} s later (attempt {attempts})", flush=True)
                httpx.post(f"{base}/api/v1/jobs/{job_id}/cancel", headers=headers, timeout=30)
                wait_row(db, job_id, lambda r: r[0] != "running", "cancel")
                time.sleep(4)  # the canceled attempt's worker notices within a heartbeat and frees its slot
        finally:
            db.close()
            for proc in (*workers, api):
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait(10)
    print(f"{'kill':<14} {'n':>3} {'min':>7} {'median':>7} {'max':>7}  (seconds from SIGKILL to the next attempt's start)")
    summary = {}
    for kind in ("pool process", "whole worker"):
        times = [r["seconds"] for r in results if r["kind"] == kind]
        if times:
            summary[kind] = {"n": len(times), "min_s": min(times), "median_s": round(statistics.median(times), 2), "max_s": max(times)}
            print(f"{kind:<14} {len(times):>3} {min(times):>7} {statistics.median(times):>7} {max(times):>7}")
    load = [round(load_before, 1), round(os.getloadavg()[0], 1)]
    print(f"1-minute load average before / after: {load[0]} / {load[1]} on {os.cpu_count()} CPUs")
    out = REPO / "bench" / "results" / "kill_retry.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"machine": {"cpus": os.cpu_count(), "platform": platform.platform(), "load_average": load},
                               "args": vars(args), "summary": summary, "kills": results}, indent=2))
    print(f"wrote {out.relative_to(REPO)}")


if __name__ == "__main__":
    main()
