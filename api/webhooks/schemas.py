"""The delivery log of a job's webhook events, as shown in the job JSON."""

from __future__ import annotations

import uuid
from datetime import datetime
from typing import Literal

from pydantic import BaseModel, Field

from api.models import WebhookDelivery


class DeliveryAttempt(BaseModel):
    at: datetime
    status_code: int | None = Field(None, description="the receiver's HTTP status; none when it could not be reached")
    error: str | None = Field(None, description="why the attempt failed; none on a 2xx")
    seconds: float


class WebhookDeliveryOut(BaseModel):
    id: uuid.UUID = Field(description="also sent as the webhook-id header: the same on every retry of one event")
    event: str = Field(description="job.succeeded, job.failed or job.canceled")
    url: str
    status: Literal["pending", "delivered", "failed"]
    attempts: list[DeliveryAttempt]
    next_attempt_at: datetime | None = Field(None, description="when the next retry is due (pending only)")
    delivered_at: datetime | None = None


def delivery_log(deliveries: list[WebhookDelivery]) -> list[WebhookDeliveryOut]:
    return [WebhookDeliveryOut(id=d.id, event=d.event, url=d.url, status=d.status,
                               attempts=[DeliveryAttempt.model_validate(a) for a in d.attempts],
                               next_attempt_at=d.next_attempt_at if d.status == "pending" else None, delivered_at=d.delivered_at)
            for d in deliveries]
