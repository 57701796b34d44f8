"""Periodic work of every worker's main process, beside the reconciler: deliver due webhooks, run the cleanup
(retention and orphaned files) and keep this worker's row fresh for /metrics. Copies in several workers are
safe: deliveries are claimed with a compare-and-set and deleting a deleted file is a no-op."""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable

from sqlalchemy import delete

from api.db import session_scope
from api.jobs.lifecycle import cleanup
from api.models import Worker, utcnow
from api.settings import Settings
from api.webhooks.dispatch import deliver_due

log = logging.getLogger("rigforge.maintenance")


class Periodic(threading.Thread):
    """Runs `action` now and then every `seconds` until `stopped` is set; a failing pass is logged, not fatal."""

    def __init__(self, name: str, seconds: float, action: Callable[[], object]) -> None:
        super().__init__(daemon=True, name=name)
        self.seconds, self.action = seconds, action
        self.stopped = threading.Event()

    def run(self) -> None:
        while not self.stopped.is_set():
            try:
                self.action()
            except Exception:  # noqa: BLE001 - keep going after a transient failure
                log.exception("%s pass failed", self.name)
            self.stopped.wait(self.seconds)


def beat(worker_id: str, concurrency: int) -> None:
    """Insert or refresh this worker's row."""
    with session_scope() as session:
        row = session.get(Worker, worker_id)
        if row is None:
            session.add(Worker(id=worker_id, concurrency=concurrency, started_at=utcnow(), last_seen_at=utcnow()))
        else:
            row.last_seen_at, row.concurrency = utcnow(), concurrency


class Maintenance:
    """The periodic threads of one worker process."""

    def __init__(self, settings: Settings, worker_id: str, concurrency: int) -> None:
        self.worker_id = worker_id
        self.threads = [
            Periodic("worker-beat", settings.jobs.heartbeat_seconds, lambda: beat(worker_id, concurrency)),
            Periodic("webhooks", settings.webhooks.poll_seconds, lambda: deliver_due(settings)),
            Periodic("cleanup", settings.cleanup_seconds, lambda: cleanup(settings)),
        ]

    def start(self) -> None:
        for thread in self.threads:
            thread.start()

    def stop(self) -> None:
        for thread in self.threads:
            thread.stopped.set()
        try:
            with session_scope() as session:
                session.execute(delete(Worker).where(Worker.id == self.worker_id))
        except Exception:  # noqa: BLE001 - its row ages out of /metrics anyway
            log.warning("could not remove worker row %s", self.worker_id, exc_info=True)
