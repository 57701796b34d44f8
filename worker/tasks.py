"""Celery tasks: thin wrappers that hand a job id to the runner."""

from __future__ import annotations

import os
import socket
import uuid

from celery.signals import worker_ready, worker_shutdown

from api.settings import get_settings
from worker.celery_app import TASK_NAME, make_celery
from worker.reconciler import Reconciler
from worker.runner import execute

app = make_celery()
_reconciler: Reconciler | None = None


@app.task(name=TASK_NAME, ignore_result=True)
def run_job(job_id: str) -> str:
    """Run job `job_id` if this delivery wins the claim."""
    return execute(uuid.UUID(job_id), get_settings(), f"{socket.gethostname()}:{os.getpid()}")


@worker_ready.connect
def _start_reconciler(**_: object) -> None:
    global _reconciler
    from worker.embedded import ready_file

    ready_file(get_settings(), os.getpid()).touch()  # tells a supervising `serve` this worker consumes
    _reconciler = Reconciler(get_settings())
    _reconciler.start()


@worker_shutdown.connect
def _stop_reconciler(**_: object) -> None:
    if _reconciler is not None:
        _reconciler.stopped.set()
