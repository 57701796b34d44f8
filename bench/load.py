"""API load: job status polls per second with p50/p99 latency while the worker is busy, the same with 500 event
streams open, and 20 concurrent 5 MB uploads, on the embedded default (SQLite + file broker) and on PostgreSQL + Redis.

Each backend runs a real `rigforge serve` (uvicorn, one embedded worker) in a fresh data directory. The worker is
kept busy with full-pipeline jobs on the dev fox (a generated box when ../shared is absent) while `--pollers`
keep-alive clients GET one job for `--seconds`: first plain GETs, then conditional ones (If-None-Match: the 304
path), after the same clients on `/healthz` (no key, no database: the reference of the HTTP stack on this machine,
this run). Then `--streams` clients open the event streams (SSE) of the busy jobs not yet finished and keep them
open while the plain GETs run again: the slow-down is the ratio of their latencies to the run without streams. Then `--uploads` threads each
POST a `--upload-mb` GLB at once; a 503/429 is retried after its Retry-After, and counted. Rate limits and quotas
are off so that the server, not the per-key limits, is measured. The pollers are minimal HTTP/1.1 clients on raw
sockets (httpx costs more CPU per request than the server's answer, on the same two cores). Server CPU is the
API process's user + system time per request (its embedded worker is a child process, not counted), client CPU this
process's. Every polling rate is also given as a fraction of the run's `/healthz` rate, and the targets of the
production issue are checked on PostgreSQL + Redis (`targets` in the JSON). Prints a table and writes bench/results/load.json.

    .venv/bin/python bench/load.py [--backends embedded,postgres] [--seconds 10] [--pollers 8] [--streams 500] [--uploads 20]
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
from collections import Counter
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
def serve(env: dict[str, str]) -> Iterator[tuple[str, str, int]]:
    """`rigforge serve` in a fresh data directory; yields (base URL, API key, its pid) once /readyz says ready."""
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
            yield base, (Path(tmp) / "local-api-key").read_text().strip(), proc.pid
        finally:
            os.killpg(proc.pid, signal.SIGTERM)
            proc.wait(60)


def percentile(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else float("nan")


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of process `pid` so far (its threads included)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


class Connection:
    """One keep-alive HTTP/1.1 connection that sends GETs and reads whole answers (Content-Length bodies)."""

    def __init__(self, base: str) -> None:
        host, port = base.removeprefix("http://").rsplit(":", 1)
        self.host = f"{host}:{port}"
        self.sock = socket.create_connection((host, int(port)), timeout=30)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.reader = self.sock.makefile("rb")

    def request(self, path: str, headers: dict[str, str]) -> tuple[int, dict[str, str], bytes]:
        lines = [f"GET {path} HTTP/1.1", f"Host: {self.host}", *(f"{k}: {v}" for k, v in headers.items())]
        self.sock.sendall(("\r\n".join(lines) + "\r\n\r\n").encode())
        return self.response()

    def response(self) -> tuple[int, dict[str, str], bytes]:
        status = int(self.reader.readline().split()[1])
        answer: dict[str, str] = {}
        while (line := self.reader.readline()) not in (b"\r\n", b""):
            name, _, value = line.decode("latin-1").partition(":")
            answer[name.strip().lower()] = value.strip()
        if answer.get("transfer-encoding") == "chunked":
            raise RuntimeError("chunked answers are not expected here")
        return status, answer, self.reader.read(int(answer.get("content-length", "0")))

    def close(self) -> None:
        self.reader.close()
        self.sock.close()


def poll(base: str, key: str, path: str, threads: int, seconds: float, conditional: bool, server_pid: int) -> dict:
    """`threads` clients GET `path` back to back for `seconds`; polls/s, latency percentiles (ms), server CPU ms/poll."""
    latencies: list[list[float]] = [[] for _ in range(threads)]
    statuses: dict[int, int] = {}
    lock = threading.Lock()
    headers = {"Authorization": f"Bearer {key}", "Accept-Encoding": "gzip, deflate"}  # as httpx and browsers send
    ready = threading.Barrier(threads + 1)
    stop = [0.0]

    def client(slot: int) -> None:
        http = Connection(base)
        mine = dict(headers)
        if conditional:
            mine["If-None-Match"] = http.request(path, headers)[1]["etag"]
        ready.wait()
        counts: dict[int, int] = {}
        while time.monotonic() < stop[0]:
            started = time.perf_counter()
            status = http.request(path, mine)[0]
            latencies[slot].append((time.perf_counter() - started) * 1000)
            counts[status] = counts.get(status, 0) + 1
        http.close()
        with lock:
            for status, n in counts.items():
                statuses[status] = statuses.get(status, 0) + n

    workers = [threading.Thread(target=client, args=(k,)) for k in range(threads)]
    for w in workers:
        w.start()
    stop[0] = time.monotonic() + seconds
    cpu_before, own_before = cpu_seconds(server_pid), cpu_seconds(os.getpid())
    ready.wait()
    for w in workers:
        w.join()
    cpu, own = cpu_seconds(server_pid) - cpu_before, cpu_seconds(os.getpid()) - own_before
    flat = [x for slot in latencies for x in slot]
    per_poll = 1000 / max(1, len(flat))
    return {"polls_per_s": round(len(flat) / seconds, 1), "p50_ms": round(percentile(flat, 50), 1),
            "p99_ms": round(percentile(flat, 99), 1), "server_cpu_ms_per_poll": round(cpu * per_poll, 3),
            "client_cpu_ms_per_poll": round(own * per_poll, 3), "statuses": statuses}


class EventStreams:
    """`count` open event streams (SSE), round-robin over `paths`, read and discarded by one thread until `close()`."""

    def __init__(self, base: str, key: str, paths: list[str], count: int) -> None:
        import selectors

        self.selector = selectors.DefaultSelector()
        self.connections: list[Connection] = []
        self.bytes_read = 0
        self.closed = 0  # streams the server closed
        for k in range(count):
            http = Connection(base)
            lines = [f"GET {paths[k % len(paths)]} HTTP/1.1", f"Host: {http.host}", f"Authorization: Bearer {key}", "Accept: text/event-stream"]
            http.sock.sendall(("\r\n".join(lines) + "\r\n\r\n").encode())
            status = int(http.reader.readline().split()[1])
            if status != 200:
                raise RuntimeError(f"event stream answered {status}")
            http.sock.setblocking(False)
            self.selector.register(http.sock, selectors.EVENT_READ)
            self.connections.append(http)
        self.stopped = threading.Event()
        self.thread = threading.Thread(target=self._drain, daemon=True)
        self.thread.start()

    def _drain(self) -> None:
        while not self.stopped.is_set():
            for ready, _ in self.selector.select(0.2):
                try:
                    data = ready.fileobj.recv(65536)  # type: ignore[union-attr]
                except BlockingIOError:
                    continue
                except OSError:
                    data = b""
                self.bytes_read += len(data)
                if not data:  # closed (a finished job's stream, then uvicorn's keep-alive timeout): it stays readable
                    self.selector.unregister(ready.fileobj)
                    self.closed += 1

    def close(self) -> None:
        self.stopped.set()
        self.thread.join()
        for http in self.connections:
            http.sock.close()


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


def job(base: str, key: str, job_id: str) -> dict:
    return httpx.get(f"{base}/api/v1/jobs/{job_id}", headers={"Authorization": f"Bearer {key}"}).json()


def status(base: str, key: str, job_id: str) -> str:
    return str(job(base, key, job_id)["status"])


def running(base: str, key: str) -> int:
    r = httpx.get(f"{base}/api/v1/jobs", params={"status": "running"}, headers={"Authorization": f"Bearer {key}"})
    return len(r.json()["items"])


def measure(name: str, env: dict[str, str], args: argparse.Namespace, upload: bytes) -> dict:
    with serve(env) as (base, key, pid):
        ids = busy_jobs(base, key, args.busy_jobs)
        busy_before = running(base, key)
        reference = poll(base, key, "/healthz", args.pollers, args.seconds, False, pid)
        plain = poll(base, key, f"/api/v1/jobs/{ids[0]}", args.pollers, args.seconds, False, pid)
        cond = poll(base, key, f"/api/v1/jobs/{ids[-1]}", args.pollers, args.seconds, True, pid)
        streams: dict = {"count": args.streams}
        if args.streams:
            alone = poll(base, key, f"/api/v1/jobs/{ids[0]}", args.pollers, args.seconds, False, pid)
            live = [i for i in ids if status(base, key, i) in ("queued", "running")] or ids  # a finished job's stream ends
            opened = time.perf_counter()
            sse = EventStreams(base, key, [f"/api/v1/jobs/{i}/events" for i in live], args.streams)
            streams["open_s"] = round(time.perf_counter() - opened, 2)
            try:
                beside = poll(base, key, f"/api/v1/jobs/{ids[0]}", args.pollers, args.seconds, False, pid)
            finally:
                sse.close()
            streams.update(alone=alone, beside=beside, slowdown_p50=round(beside["p50_ms"] / alone["p50_ms"], 2),
                           slowdown_p99=round(beside["p99_ms"] / alone["p99_ms"], 2),
                           rate_ratio=round(alone["polls_per_s"] / beside["polls_per_s"], 2), bytes_read=sse.bytes_read,
                           open_at_end=args.streams - sse.closed)
        busy_after = running(base, key)
        busy = [job(base, key, i) for i in ids]
        uploads = upload_all(base, key, upload, args.uploads)
    ends = [f"{j['status']}:{j['stage']}" + (f":{j['error']['code']}" if j["error"] else "") for j in busy]
    for run in (plain, cond, streams.get("alone"), streams.get("beside")):
        if run is not None:
            run["of_healthz_rate"] = round(run["polls_per_s"] / reference["polls_per_s"], 2)
    return {"backend": name, "busy_jobs": ends, "healthz_reference": reference, "poll": plain, "poll_if_none_match": cond, "event_streams": streams,
            "uploads": uploads, "worker_running_jobs": [busy_before, busy_after]}


def targets(row: dict) -> dict:
    """The production issue's targets on PostgreSQL + Redis: >= 1,000 polls/s at p99 < 50 ms with the worker busy, and
    open event streams slowing other polls at most 2x (p50 and p99)."""
    plain, streams = row["poll"], row["event_streams"]
    slowdown = max(streams.get("slowdown_p50", 0.0), streams.get("slowdown_p99", 0.0))
    return {"polls_per_s_at_least_1000": plain["polls_per_s"] >= 1000, "p99_under_50_ms": plain["p99_ms"] < 50,
            "worker_busy": min(row["worker_running_jobs"]) > 0, "streams_slowdown_at_most_2x": slowdown <= 2 if streams["count"] else None}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--backends", default="embedded,postgres", help="comma-separated: embedded, postgres")
    parser.add_argument("--seconds", type=float, default=10.0, help="length of each polling run")
    parser.add_argument("--pollers", type=int, default=8, help="concurrent polling clients")
    parser.add_argument("--busy-jobs", type=int, default=40, help="full-pipeline jobs queued to keep the worker busy throughout")
    parser.add_argument("--streams", type=int, default=500, help="event streams held open during the last polling run (0: none)")
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
            rows[-1]["targets"] = targets(rows[-1])
        else:
            parser.error(f"unknown backend {name!r}")
    print(f"{'backend':<20} {'test':<40} {'rate':>9} {'p50':>9} {'p99':>9} {'CPU/req':>9} {'client':>9}  notes")

    def line(backend: str, test: str, r: dict, notes: str = "") -> None:
        share = f"{r['of_healthz_rate']} of /healthz's rate; " if "of_healthz_rate" in r else ""
        print(f"{backend:<20} {test:<40} {r['polls_per_s']:>7}/s {r['p50_ms']:>6} ms {r['p99_ms']:>6} ms "
              f"{r['server_cpu_ms_per_poll']:>6} ms {r['client_cpu_ms_per_poll']:>6} ms  {share}{notes}")

    for r in rows:
        b = r["backend"].replace(" (SQLite + files)", "")
        line(b, "GET /healthz (reference: no DB)", r["healthz_reference"])
        line(b, f"GET job ({args.pollers} clients)", r["poll"],
             f"worker running {r['worker_running_jobs'][0]} job(s) before, {r['worker_running_jobs'][1]} after; "
             f"busy jobs at the end: {', '.join(f'{n} {k}' for k, n in Counter(j.split(':')[0] for j in r['busy_jobs']).items())}")
        line(b, "GET job, If-None-Match (304)", r["poll_if_none_match"], f"statuses {r['poll_if_none_match']['statuses']}")
        s = r["event_streams"]
        if s["count"]:
            line(b, "GET job, again", s["alone"])
            line(b, f"GET job, {s['count']} event streams open", s["beside"],
                 f"slow-down p50 {s['slowdown_p50']}x, p99 {s['slowdown_p99']}x, rate {s['rate_ratio']}x; opened in {s['open_s']} s, "
                 f"{s['open_at_end']} still open at the end")
        u = r["uploads"]
        uploads = f"{args.uploads} concurrent {u['size_mb']} MB uploads"
        print(f"{b:<20} {uploads:<40} {u['mb_per_s']:>5} MB/s {u['p50_s']:>7} s {u['p99_s']:>7} s {'':>9} {'':>9}  "
              f"wall {u['wall_s']} s, {u['accepted']} accepted, {u['retries']} retries after 503/429")
        if "targets" in r:
            print(f"{b:<20} targets: " + ", ".join(f"{k} {v}" for k, v in r["targets"].items()))
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
