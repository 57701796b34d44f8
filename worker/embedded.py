"""The embedded worker of `rigforge serve`: a supervised `rigforge worker` process group.

A supervisor thread restarts the worker when it dies or stops consuming. Consuming is judged from the job
rows (the one source of truth), so it catches any wedge, whatever its cause: a ready worker is stuck when
jobs wait in `queued`, none runs under a live lease and none was claimed for `worker_stall_seconds` on end.
It is the safety net: the known causes of such wedges after killed pool processes (billiard's shared job-pipe
lock, SQLite locks inherited across fork) are fixed in worker.filesystem_transport and worker.fork_guard. The worker runs in its own
process group, and the whole group is killed on stop, so no pool child outlives `serve`.
"""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import threading
import time
from functools import partial
from pathlib import Path

from sqlalchemy import func, select

from api.db import session_scope
from api.jobs.state import now
from api.models import Job
from api.settings import Settings

log = logging.getLogger("rigforge.embedded")
_active: EmbeddedWorker | None = None


def active() -> EmbeddedWorker | None:
    """The supervised worker of this process, when `serve` runs one."""
    return _active


def _child_setup(nice: int) -> None:
    """In the child: get SIGTERM when the parent dies (a SIGKILLed `serve` runs no cleanup), and yield the CPU to the
    API by `nice` (its pool processes inherit it)."""
    import ctypes

    ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # 1 = PR_SET_PDEATHSIG
    os.nice(nice)


def kill_group(proc: subprocess.Popen, grace: float) -> None:
    """SIGTERM the process group led by `proc`, SIGKILL it after `grace` s; reap the leader."""
    for sig, wait in ((signal.SIGTERM, grace), (signal.SIGKILL, 10.0)):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            break
        try:
            proc.wait(wait)
        except subprocess.TimeoutExpired:
            continue
        try:  # the leader is gone; pool children of a wedged worker may not be
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        break


def ready_file(settings: Settings, pid: int) -> Path:
    """Written by a worker process once it consumes (Celery's worker_ready), named by its pid."""
    return settings.data_dir / f"worker-ready-{pid}"


def queue_state() -> tuple[bool, object]:
    """(jobs wait queued with none running under a live lease, the latest claim time: it moves while jobs are taken)."""
    t = now()
    with session_scope() as session:
        waiting = session.scalar(select(func.count()).select_from(Job).where(Job.status == "queued"))
        running = session.scalar(select(func.count()).select_from(Job).where(Job.status == "running", Job.lease_expires_at > t))
        latest = session.scalar(select(func.max(Job.started_at)))
    return bool(waiting) and not running, latest


class EmbeddedWorker(threading.Thread):
    """Starts `command` as a process group and keeps one alive and consuming until `stop()`."""

    def __init__(self, settings: Settings, command: list[str] | None = None) -> None:
        super().__init__(daemon=True, name="embedded-worker")
        self.settings = settings
        self.command = command or [sys.executable, "-m", "cli.main", "worker"]
        self.proc: subprocess.Popen | None = None
        self.restarts = 0
        self.problem: str | None = None  # why it was last restarted, until a check finds it healthy
        self.started_at = 0.0
        self.starved_since: float | None = None  # since when jobs wait, none runs and none was taken (seen by check)
        self.latest_claim: object = None
        self._stop = threading.Event()
        self._lock = threading.Lock()

    def _spawn(self) -> None:
        self.proc = subprocess.Popen(self.command, start_new_session=True, preexec_fn=partial(_child_setup, self.settings.jobs.worker_nice))
        self.started_at, self.starved_since = time.monotonic(), None

    def _restart(self, reason: str) -> None:
        log.warning("embedded worker %s; restarting it", reason)
        with self._lock:
            self.problem = reason
            self._end(grace=5.0)
            if not self._stop.is_set():
                self._spawn()
                self.restarts += 1

    def _end(self, grace: float) -> None:
        if self.proc is not None:
            kill_group(self.proc, grace)
            ready_file(self.settings, self.proc.pid).unlink(missing_ok=True)

    def check(self) -> None:
        """One supervision pass: restart a worker that died, never got ready, or takes no queued job."""
        stall = self.settings.jobs.worker_stall_seconds
        proc = self.proc
        assert proc is not None, "check() runs after run() spawned the worker"
        if proc.poll() is not None:
            self._restart(f"exited with status {proc.returncode}")
            return
        if not ready_file(self.settings, proc.pid).exists():
            if time.monotonic() - self.started_at > max(stall, 120.0):
                self._restart("did not start consuming")
            return
        starved, latest = queue_state()
        if not starved or latest != self.latest_claim:
            self.starved_since, self.latest_claim, self.problem = None, latest, None
        elif self.starved_since is None:
            self.starved_since = time.monotonic()
        elif time.monotonic() - self.starved_since > stall:
            self._restart(f"took no queued job for {stall:g} s")

    def run(self) -> None:
        global _active
        _active = self
        with self._lock:
            self._spawn()
        while not self._stop.wait(self.settings.jobs.worker_check_seconds):
            try:
                self.check()
            except Exception:  # noqa: BLE001 - a transient database error must not end supervision
                log.exception("embedded worker check failed")

    def status(self) -> str:
        """'ok', or why the worker is not ready (for /readyz)."""
        if self.proc is None or self.proc.poll() is not None:
            return "error: no worker process is alive"
        if not ready_file(self.settings, self.proc.pid).exists():
            return "error: the worker is starting" + (f" (restarted after it {self.problem})" if self.problem else "")
        return "ok"

    def stop(self, grace: float = 15.0) -> None:
        """Stop supervising and kill the worker's whole process group."""
        global _active
        self._stop.set()
        with self._lock:
            self._end(grace)
        if _active is self:
            _active = None
