"""Periodic recovery of lost jobs, run in a thread of every worker's main process (CAS makes copies safe)."""

from __future__ import annotations

import logging
import threading

from api.db import session_scope
from api.jobs import state
from api.settings import Settings

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
