"""API load: job status polls per second with p50/p99 latency while the worker is busy, and 20 concurrent 5 MB
uploads, on the embedded default (SQLite + file broker) and on PostgreSQL + Redis.

Each backend runs a real `rigforge serve` (uvicorn, one embedded worker) in a fresh data directory. The worker is
kept busy with full-pipeline jobs on the dev fox (a generated box when ../shared is absent) while `--pollers`
threads GET one job for `--seconds`: first plain GETs, then conditional ones (If-None-Match: the 304 path), after
the same clients on `/healthz` (no key, no database: the reference of the HTTP stack on this machine, this run). Then
`--uploads` threads each POST a `--upload-mb` GLB at once; a 503/429 is retried after its Retry-After, and
counted. Rate limits and quotas are off so that the server, not the per-key limits, is measured. Prints a table
and writes bench/results/load.json.

    .venv/bin/python bench/load.py [--backends embedded,postgres] [--seconds 10] [--pollers 8] [--uploads 20]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import cast

import httpx
import numpy as np
import trimesh

REPO = Path(__file__).resolve().parents[1]
DEV = Path(os.environ.get("RIGFORGE_DEV_ASSETS", REPO.parent / "shared" / "assets" / "dev"))
PG_ADMIN = "postgresql://postgres@127.0.0.1:5432/postgres"
REDIS_URL = "redis://127.0.0.1:6379/9"
INGEST_ONLY = '{"stages": []}'
UNLIMITED = {"RIGFORGE_RATE_LIMIT": "", "RIGFORGE_QUOTAS__CONCURRENT_JOBS": "0", "RIGFORGE_QUOTAS__JOBS_PER_HOUR": "0",
             "RIGFORGE_QUOTAS__STORAGE_MB": "0"}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def grid_glb(megabytes: float) -> bytes:
    """A flat triangle grid whose GLB is about `megabytes` (positions and uint32 indices: ~36 bytes a vertex)."""
    n = int(np.sqrt(megabytes * 1024 * 1024 / 36))
    u, v = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    vertices = np.stack([u.ravel(), np.zeros(n * n), v.ravel()], axis=1)
    k = np.arange((n - 1) * (n - 1))
    i, j = k // (n - 1), k % (n - 1)
    a = i * n + j
    faces = np.concatenate([np.stack([a, a + n, a + 1], 1), np.stack([a + 1, a + n, a + n + 1], 1)])
    return glb(trimesh.Trimesh(vertices, faces, process=False))


def glb(mesh: trimesh.Trimesh) -> bytes:
    return cast(bytes, mesh.export(file_type="glb"))


@contextmanager
def postgres_and_redis() -> Iterator[dict[str, str]]:
    """A fresh PostgreSQL database and a flushed Redis database, as RIGFORGE_ settings."""
    import psycopg
    import redis

    name = f"rigforge_bench_{uuid.uuid4().hex[:8]}"
    admin = psycopg.connect(PG_ADMIN, autocommit=True, connect_timeout=3)
    admin.execute(f'CREATE DATABASE "{name}"')
    redis.Redis.from_url(REDIS_URL).flushdb()
    try:
        yield {"RIGFORGE_DATABASE_URL": f"postgresql+psycopg://postgres@127.0.0.1:5432/{name}", "RIGFORGE_BROKER_URL": REDIS_URL}
    finally:
        admin.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')
        admin.close()


@contextmanager
def serve(env: dict[str, str]) -> Iterator[tuple[str, str]]:
    """`rigforge serve` in a fresh data directory; yields (base URL, API key) once /readyz says ready."""
    with tempfile.TemporaryDirectory(prefix="rigforge-load-") as tmp:
        port = free_port()
        full = {**os.environ, **UNLIMITED, **env, "RIGFORGE_DATA_DIR": tmp}
        proc = subprocess.Popen([sys.executable, "-m", "cli.main", "serve", "--port", str(port)], cwd=REPO, env=full,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        base = f"http://127.0.0.1:{port}"
        try:
            deadline = time.monotonic() + 180
            while time.monotonic() < deadline:
                try:
                    if httpx.get(f"{base}/readyz", timeout=5).status_code == 200:
                        break
                except httpx.HTTPError:
                    pass
                if proc.poll() is not None:
                    raise RuntimeError(f"rigforge serve exited with {proc.returncode}")
                time.sleep(0.5)
            else:
                raise RuntimeError("rigforge serve did not become ready in 180 s")
            yield base, (Path(tmp) / "local-api-key").read_text().strip()
        finally:
            os.killpg(proc.pid, signal.SIGTERM)
            proc.wait(60)


def percentile(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else float("nan")


def poll(base: str, key: str, path: str, threads: int, seconds: float, conditional: bool) -> dict:
    """`threads` clients GET `path` back to back for `seconds`; polls/s and latency percentiles (ms)."""
    latencies: list[list[float]] = [[] for _ in range(threads)]
    statuses: dict[int, int] = {}
    lock = threading.Lock()
    stop = time.monotonic() + seconds

    def client(slot: int) -> None:
        headers = {"Authorization": f"Bearer {key}"}
        with httpx.Client(base_url=base, headers=headers, timeout=30) as http:
            if conditional:
                headers["If-None-Match"] = http.get(path).headers["etag"]
            while time.monotonic() < stop:
                started = time.perf_counter()
                r = http.get(path, headers=headers)
                latencies[slot].append((time.perf_counter() - started) * 1000)
                with lock:
                    statuses[r.status_code] = statuses.get(r.status_code, 0) + 1

    workers = [threading.Thread(target=client, args=(k,)) for k in range(threads)]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    flat = [x for slot in latencies for x in slot]
    return {"polls_per_s": round(len(flat) / seconds, 1), "p50_ms": round(percentile(flat, 50), 1),
            "p99_ms": round(percentile(flat, 99), 1), "statuses": statuses}


def upload_all(base: str, key: str, data: bytes, count: int) -> dict:
    """`count` threads POST `data` at once (retrying 503/429 after Retry-After); wall time and latency per upload."""
    results: list[tuple[float, int, int]] = []
    lock = threading.Lock()
    released: list[float] = []  # when every client is ready to send: the wall time starts there
    barrier = threading.Barrier(count, action=lambda: released.append(time.perf_counter()))

    def one() -> None:
        retries = 0
        with httpx.Client(base_url=base, headers={"Authorization": f"Bearer {key}"}, timeout=300) as http:
            barrier.wait()
            started = time.perf_counter()
            while True:
                r = http.post("/api/v1/jobs", files={"mesh": ("grid.glb", data)}, data={"options": INGEST_ONLY})
                if r.status_code not in (429, 503):
                    break
                retries += 1
                time.sleep(float(r.headers.get("retry-after", "1")))
        with lock:
            results.append((time.perf_counter() - started, r.status_code, retries))

    threads = [threading.Thread(target=one) for _ in range(count)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    wall = time.perf_counter() - released[0]
    seconds = [r[0] for r in results]
    return {"wall_s": round(wall, 2), "p50_s": round(statistics.median(seconds), 2), "p99_s": round(percentile(seconds, 99), 2),
            "mb_per_s": round(count * len(data) / 2**20 / wall, 1), "accepted": sum(r[1] == 202 for r in results),
            "retries": sum(r[2] for r in results), "size_mb": round(len(data) / 2**20, 2)}


def busy_jobs(base: str, key: str, count: int) -> list[str]:
    """Queue `count` full-pipeline jobs and wait until the worker runs the first."""
    mesh = (DEV / "fox.glb").read_bytes() if (DEV / "fox.glb").exists() else glb(trimesh.creation.box())
    headers = {"Authorization": f"Bearer {key}"}
    ids = [httpx.post(f"{base}/api/v1/jobs", headers=headers, files={"mesh": ("fox.glb", mesh)}, timeout=60).json()["id"]
           for _ in range(count)]
    deadline = time.monotonic() + 120
    while httpx.get(f"{base}/api/v1/jobs/{ids[0]}", headers=headers).json()["status"] == "queued":
        if time.monotonic() > deadline:
            raise RuntimeError("the worker took no job in 120 s")
        time.sleep(0.2)
    return ids


def running(base: str, key: str) -> int:
    r = httpx.get(f"{base}/api/v1/jobs", params={"status": "running"}, headers={"Authorization": f"Bearer {key}"})
    return len(r.json()["items"])


def measure(name: str, env: dict[str, str], args: argparse.Namespace, upload: bytes) -> dict:
    with serve(env) as (base, key):
        ids = busy_jobs(base, key, args.busy_jobs)
        busy_before = running(base, key)
        reference = poll(base, key, "/healthz", args.pollers, args.seconds, conditional=False)
        plain = poll(base, key, f"/api/v1/jobs/{ids[0]}", args.pollers, args.seconds, conditional=False)
        cond = poll(base, key, f"/api/v1/jobs/{ids[-1]}", args.pollers, args.seconds, conditional=True)
        busy_after = running(base, key)
        uploads = upload_all(base, key, upload, args.uploads)
    return {"backend": name, "healthz_reference": reference, "poll": plain, "poll_if_none_match": cond, "uploads": uploads,
            "worker_running_jobs": [busy_before, busy_after]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--backends", default="embedded,postgres", help="comma-separated: embedded, postgres")
    parser.add_argument("--seconds", type=float, default=10.0, help="length of each polling run")
    parser.add_argument("--pollers", type=int, default=8, help="concurrent polling clients")
    parser.add_argument("--busy-jobs", type=int, default=4, help="full-pipeline jobs queued to keep the worker busy")
    parser.add_argument("--uploads", type=int, default=20, help="concurrent uploads")
    parser.add_argument("--upload-mb", type=float, default=5.0, help="size of each uploaded GLB")
    args = parser.parse_args()
    upload = grid_glb(args.upload_mb)
    load_before = os.getloadavg()
    rows = []
    for name in args.backends.split(","):
        if name == "embedded":
            rows.append(measure("embedded (SQLite + files)", {}, args, upload))
        elif name == "postgres":
            with postgres_and_redis() as env:
                rows.append(measure("PostgreSQL + Redis", env, args, upload))
        else:
            parser.error(f"unknown backend {name!r}")
    print(f"{'backend':<26} {'test':<34} {'rate':>11} {'p50':>9} {'p99':>9}  notes")
    for r in rows:
        h, p, c, u = r["healthz_reference"], r["poll"], r["poll_if_none_match"], r["uploads"]
        print(f"{r['backend']:<26} {'GET /healthz (reference: no DB)':<34} {h['polls_per_s']:>9}/s {h['p50_ms']:>6} ms {h['p99_ms']:>6} ms")
        print(f"{r['backend']:<26} {f'GET job ({args.pollers} clients)':<34} {p['polls_per_s']:>9}/s {p['p50_ms']:>6} ms {p['p99_ms']:>6} ms"
              f"  worker running {r['worker_running_jobs'][0]} job(s) before, {r['worker_running_jobs'][1]} after")
        print(f"{r['backend']:<26} {'GET job, If-None-Match (304)':<34} {c['polls_per_s']:>9}/s {c['p50_ms']:>6} ms {c['p99_ms']:>6} ms"
              f"  statuses {c['statuses']}")
        uploads = f"{args.uploads} concurrent {u['size_mb']} MB uploads"
        print(f"{r['backend']:<26} {uploads:<34} {u['mb_per_s']:>7} MB/s {u['p50_s']:>7} s "
              f"{u['p99_s']:>7} s  wall {u['wall_s']} s, {u['accepted']} accepted, {u['retries']} retries after 503/429")
    load = [round(x, 1) for x in (*load_before[:1], os.getloadavg()[0])]
    print(f"1-minute load average before / after: {load[0]} / {load[1]} on {os.cpu_count()} CPUs (other work on the machine "
          "competes with the server and its worker)")
    out = REPO / "bench" / "results" / "load.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"machine": {"cpus": os.cpu_count(), "platform": platform.platform(), "load_average": load}, "args": vars(args),
                               "results": rows}, indent=2))
    print(f"wrote {out.relative_to(REPO)}")



if __name__ == "__main__":
    main()
