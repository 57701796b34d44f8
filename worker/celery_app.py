"""The Celery application. Celery only delivers job ids; the job row is the source of truth.

Config choices (why):
- acks_late + prefetch 1: a message is acknowledged only after its task returns, and a worker holds at
  most one job it has not started, so a crash loses no message it took.
- no result backend: results live in the database row, not in Celery.
- soft/hard time limits per job; the Redis visibility timeout is above the hard limit so Redis never
  re-delivers a job that is still legitimately running. It does not decide how fast a lost job comes back: the
  job row's lease does (worker.reconciler: a killed pool process's job is re-sent at once, a dead worker's once
  its lease expires, 15 s after its last heartbeat by default, plus at most one 2 s reconciler period).
- filesystem:// (the embedded default) keeps the queue in files under the data directory: no server. Its
  transport is polled from the worker's event loop (worker.filesystem_transport), so a killed pool process
  cannot wedge the worker.
- two queues, `cpu` and `gpu` (worker.routing decides which a job goes to); `rigforge worker --queues` picks.
"""

from __future__ import annotations

import uuid
from functools import lru_cache

from celery import Celery

from api.settings import Settings, get_settings
from worker.routing import CPU_QUEUE, queue_for

TASK_NAME = "rigforge.run_job"


def _broker_options(settings: Settings) -> tuple[str, dict]:
    if settings.broker_url.startswith("filesystem://"):
        folder = settings.broker_dir / "queue"
        folder.mkdir(parents=True, exist_ok=True)
        (settings.broker_dir / "processed").mkdir(parents=True, exist_ok=True)
        return "filesystem://", {"data_folder_in": str(folder), "data_folder_out": str(folder),
                                 "processed_folder": str(settings.broker_dir / "processed"), "store_processed": False,
                                 "control_folder": str(settings.broker_dir / "control")}  # else ./control in the cwd
    return settings.broker_url, {"visibility_timeout": settings.jobs.time_limit + 300}


@lru_cache
def make_celery() -> Celery:
    """Build the app from the current settings (cached per process)."""
    settings = get_settings()
    broker, options = _broker_options(settings)
    app = Celery("rigforge", broker=broker, include=["worker.tasks"])
    app.conf.update(
        task_acks_late=True,
        task_reject_on_worker_lost=True,
        worker_prefetch_multiplier=1,
        task_ignore_result=True,
        result_backend=None,
        task_default_queue=CPU_QUEUE,
        task_soft_time_limit=settings.jobs.soft_time_limit,
        task_time_limit=settings.jobs.time_limit,
        broker_transport_options=options,
        broker_transport="worker.filesystem_transport:Transport" if broker.startswith("filesystem") else None,
        broker_connection_retry_on_startup=True,
        worker_hijack_root_logger=False,
        worker_enable_remote_control=not broker.startswith("filesystem"),  # fanout needs a real broker
        task_serializer="json",
        accept_content=["json"],
    )
    return app


def enqueue(job_id: str) -> None:
    """Send a job id to the workers, on the queue its work belongs to (worker.routing)."""
    make_celery().send_task(TASK_NAME, args=[job_id], queue=queue_for(uuid.UUID(job_id)))
