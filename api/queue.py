"""Hand a committed job to the broker and record when it was sent."""

from __future__ import annotations

import logging
import uuid

from api.db import session_scope
from api.jobs.state import mark_enqueued

log = logging.getLogger("rigforge.queue")


def enqueue_job(job_id: uuid.UUID) -> None:
    """Send the job id; a broker failure is logged and left to the reconciler, which re-sends queued jobs."""
    from worker.celery_app import enqueue  # celery only, no torch

    try:
        enqueue(str(job_id))
    except Exception:  # noqa: BLE001 - the job row stays queued; the reconciler retries
        log.exception("could not enqueue job %s; the reconciler will re-send it", job_id)
        return
    with session_scope() as session:
        mark_enqueued(session, job_id)
