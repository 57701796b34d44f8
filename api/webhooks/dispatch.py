"""Deliver due webhook events: POST, record the attempt, retry with exponential backoff until max_attempts.

Runs in every worker's maintenance thread (worker.maintenance). Each delivery is claimed with a compare-and-set
on its `next_attempt_at`, so several workers never send one attempt twice; a worker that dies mid-attempt
leaves the delivery due again once its hold expires. Events survive restarts: they live in the database.
"""

from __future__ import annotations

import json
import logging
import time
import uuid
from datetime import timedelta

import httpx
from sqlalchemy import select, update

from api import changes
from api.db import rowcount, session_scope
from api.models import ApiKey, WebhookDelivery, utcnow
from api.settings import Settings, WebhookSettings
from api.webhooks.signing import new_secret, signed_headers

log = logging.getLogger("rigforge.webhooks")
BATCH = 20
ERROR_CHARS = 300


def backoff_seconds(failed_attempts: int, settings: WebhookSettings) -> float:
    """Wait after the n-th failed attempt: backoff_seconds × 2^(n-1), at most backoff_max_seconds."""
    return min(settings.backoff_seconds * 2 ** (failed_attempts - 1), settings.backoff_max_seconds)


def signing_secret(owner_id: uuid.UUID) -> str:
    """The key's signing secret (made on first use for a key that has none)."""
    with session_scope() as session:
        key = session.get_one(ApiKey, owner_id)
        if key.webhook_secret is None:
            key.webhook_secret = new_secret()
        return key.webhook_secret


def claim_due(settings: WebhookSettings) -> list[WebhookDelivery]:
    """Due pending deliveries this process now holds for one attempt (held for the timeout plus slack)."""
    t = utcnow()
    hold = t + timedelta(seconds=settings.timeout_seconds + 30)
    claimed = []
    with session_scope() as session:
        due = session.scalars(select(WebhookDelivery).where(WebhookDelivery.status == "pending", WebhookDelivery.next_attempt_at <= t)
                              .order_by(WebhookDelivery.next_attempt_at).limit(BATCH)).all()
        for delivery in due:
            won = session.execute(update(WebhookDelivery)
                                  .where(WebhookDelivery.id == delivery.id, WebhookDelivery.status == "pending",
                                         WebhookDelivery.next_attempt_at == delivery.next_attempt_at)
                                  .values(next_attempt_at=hold).execution_options(synchronize_session=False))
            session.commit()
            if rowcount(won) == 1:
                claimed.append(delivery)
    return claimed


def send(delivery: WebhookDelivery, secret: str, client: httpx.Client) -> dict:
    """One signed POST; the attempt as logged on the delivery: {at, status_code, error, seconds}."""
    body = json.dumps(delivery.payload, separators=(",", ":")).encode()
    at, started = utcnow(), time.monotonic()
    headers = signed_headers(secret, str(delivery.id), int(time.time()), body) | {"user-agent": "RigForge-Webhooks/1"}
    status_code, error = None, None
    try:
        response = client.post(delivery.url, content=body, headers=headers)
        status_code = response.status_code
        if not response.is_success:
            error = f"HTTP {status_code}"
    except httpx.HTTPError as exc:
        error = f"{type(exc).__name__}: {exc}"[:ERROR_CHARS]
    return {"at": at.isoformat(), "status_code": status_code, "error": error, "seconds": round(time.monotonic() - started, 3)}


def record_attempt(delivery_id: uuid.UUID, attempt: dict, settings: WebhookSettings) -> str:
    """Append the attempt; the delivery becomes delivered, pending (next retry scheduled) or failed. Returns that."""
    with session_scope() as session:
        delivery = session.get_one(WebhookDelivery, delivery_id)
        attempts = [*delivery.attempts, attempt]
        if attempt["error"] is None:
            status, next_at, delivered = "delivered", None, utcnow()
        elif len(attempts) >= settings.max_attempts:
            status, next_at, delivered = "failed", None, None
        else:
            status, next_at, delivered = "pending", utcnow() + timedelta(seconds=backoff_seconds(len(attempts), settings)), None
        delivery.attempts, delivery.status, delivery.next_attempt_at, delivery.delivered_at = attempts, status, next_at, delivered
        job_id = delivery.job_id
    if job_id is not None:
        changes.publish("job", job_id)  # the job's JSON lists its deliveries
    return status


def deliver_due(settings: Settings) -> int:
    """One dispatcher pass: send every due delivery once. Returns how many were attempted."""
    claimed = claim_due(settings.webhooks)
    if not claimed:
        return 0
    with httpx.Client(timeout=settings.webhooks.timeout_seconds, follow_redirects=False) as client:
        for delivery in claimed:
            outcome = record_attempt(delivery.id, send(delivery, signing_secret(delivery.owner_id), client), settings.webhooks)
            log.info("webhook %s for job %s to %s: %s", delivery.event, delivery.job_id, delivery.url, outcome,
                     extra={"job_id": str(delivery.job_id)})
    return len(claimed)
