"""Record webhook events in the same transaction as the job transition that causes them (an outbox: an event
is never lost to a crash between the two, and it is delivered by a worker's dispatcher, never by the job)."""

from __future__ import annotations

import uuid

from sqlalchemy.orm import Session

from api.models import ApiKey, Job, WebhookDelivery, utcnow

EVENTS = ("job.succeeded", "job.failed", "job.canceled")


def job_payload(job: Job, event: str) -> dict:
    """The body of one event: Standard Webhooks' {type, timestamp, data}; fetch the job for download URLs."""
    error = {"code": job.error_code, "message": job.error_message or ""} if job.error_code and job.status != "succeeded" else None
    return {
        "type": event,
        "timestamp": utcnow().isoformat(),
        "data": {
            "id": str(job.id), "status": job.status, "stage": job.stage, "progress": job.progress,
            "finished_at": job.finished_at.isoformat() if job.finished_at else None, "error": error,
            "warnings": len(job.warnings or []),
            "artifacts": [{"name": a.name, "size": a.size, "sha256": a.sha256} for a in job.artifacts],
            "url": f"/api/v1/jobs/{job.id}",
        },
    }


def record(session: Session, job_id: uuid.UUID, event: str) -> WebhookDelivery | None:
    """Queue `event` for the job's callback URL (or its key's default); None when neither is set.
    Runs inside the caller's transaction; the caller commits."""
    session.flush()
    job = session.get(Job, job_id, populate_existing=True)
    if job is None:
        return None
    url = job.callback_url
    if url is None:
        key = session.get(ApiKey, job.owner_id)
        url = key.webhook_url if key is not None else None
    if url is None:
        return None
    delivery = WebhookDelivery(job_id=job.id, owner_id=job.owner_id, event=event, url=url, payload=job_payload(job, event),
                               status="pending", attempts=[], next_attempt_at=utcnow())
    session.add(delivery)
    return delivery
