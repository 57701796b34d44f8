"""Recovery of lost jobs, two ways (claims are compare-and-set, so any number of copies is safe):

- a pool process that dies mid-job (SIGKILL, the OOM killer) is noticed at once by its worker's main process,
  which re-queues the job it was running and sends it again (`LostJobRequest`): the retry starts as soon as a
  worker slot is free (bench/kill_retry.py measures both ways);
- a whole worker that dies (host lost, main process killed) stops renewing its jobs' leases: the reconciler thread
  of every other worker re-queues a running job once its lease has expired. A job is retried at most
  `lease_seconds` + `reconcile_seconds` after the kill (15 + 2 s by default; heartbeats every 3 s).
"""

from __future__ import annotations

import logging
import threading
import uuid
from typing import Any

from billiard.einfo import ExceptionWithTraceback
from billiard.exceptions import WorkerLostError
from celery.worker.request import Request

from api.db import session_scope
from api.jobs import state
from api.settings import Settings, get_settings

log = logging.getLogger("rigforge.reconciler")


def reconcile_once(settings: Settings) -> tuple[int, int]:
    """One pass: re-send re-queued/stale jobs, fail those out of attempts. Returns (requeued, failed)."""
    from worker.celery_app import enqueue

    with session_scope() as session:
        requeue, lost = state.reconcile(session, settings.jobs.max_attempts, settings.jobs.requeue_after_seconds)
    for job_id in requeue:
        enqueue(str(job_id))
    if requeue or lost:
        log.info("reconciler: re-queued %d, failed %d", len(requeue), len(lost))
    return len(requeue), len(lost)


def release_dead_attempt(job_id: str, pid: int, settings: Settings) -> str | None:
    """The pool process `pid` of this host died running `job_id`: re-queue and re-send the job now (or fail it past
    max_attempts). Returns the job's new status, or None when that process no longer held it."""
    from worker.celery_app import enqueue

    with session_scope() as session:
        status = state.release_lost(session, uuid.UUID(job_id), state.worker_id(pid), settings.jobs.max_attempts)
    if status == "queued":
        enqueue(job_id)
    if status is not None:
        log.warning("pool process %d died running job %s: %s", pid, job_id, "re-queued" if status == "queued" else status,
                    extra={"job_id": job_id})
    return status


class LostJobRequest(Request):
    """Celery's request of a job delivery, in the worker's main process: when the pool process running it dies, the
    job is re-queued at once instead of when its lease expires. Celery then re-queues the message itself as well
    (task_reject_on_worker_lost); whichever copy comes first claims the job, the other is skipped."""

    def on_failure(self, exc_info: Any, send_failed_event: bool = True, return_ok: bool = False) -> None:
        exc = exc_info.exception
        if isinstance(exc, ExceptionWithTraceback):
            exc = exc.exc
        if isinstance(exc, WorkerLostError) and self.worker_pid and self.args:
            try:
                release_dead_attempt(str(self.args[0]), int(self.worker_pid), get_settings())
            except Exception:  # noqa: BLE001 - the lease and the reconciler still recover it
                log.exception("could not re-queue the job of dead pool process %s", self.worker_pid)
        super().on_failure(exc_info, send_failed_event=send_failed_event, return_ok=return_ok)


class Reconciler(threading.Thread):
    def __init__(self, settings: Settings) -> None:
        super().__init__(daemon=True, name="reconciler")
        self.settings = settings
        self.stopped = threading.Event()

    def run(self) -> None:
        while not self.stopped.wait(self.settings.jobs.reconcile_seconds):
            try:
                reconcile_once(self.settings)
            except Exception:  # noqa: BLE001 - keep reconciling after a transient failure
                log.exception("reconcile pass failed")
