"""/api/v1/keys/me/webhook: the calling key's default webhook URL and its signing secret.

The secret is shown to whoever holds the API key (the same trust as submitting jobs with it), and rotating it
invalidates the old one at once: deliveries still pending are signed with the new secret.
"""

from __future__ import annotations

import uuid

from fastapi import APIRouter
from pydantic import BaseModel, Field

from api.auth import CurrentKey
from api.db import session_scope
from api.models import ApiKey
from api.problem_schema import problem_responses
from api.webhooks.signing import new_secret
from api.webhooks.urls import checked_callback_url

router = APIRouter(prefix="/api/v1/keys/me/webhook", tags=["keys"], responses=problem_responses(401, 429))


class WebhookConfig(BaseModel):
    url: str | None = Field(None, description="default callback of this key's jobs (a job's own callback_url wins)")
    secret: str = Field(description="Standard Webhooks signing secret (whsec_...) of every delivery to this key's URLs")


class WebhookUrl(BaseModel):
    url: str | None = Field(None, description="an http(s) URL, or null to stop default deliveries",
                            examples=["https://ci.example.com/rigforge-hook"])


def _config(key_id: uuid.UUID, *, url: str | None = None, set_url: bool = False, rotate: bool = False) -> WebhookConfig:
    with session_scope() as session:
        key = session.get_one(ApiKey, key_id)
        if set_url:
            key.webhook_url = url
        if rotate or key.webhook_secret is None:
            key.webhook_secret = new_secret()
        return WebhookConfig(url=key.webhook_url, secret=key.webhook_secret)


@router.get("", response_model=WebhookConfig, summary="This key's default webhook URL and signing secret")
def get_key_webhook(key: CurrentKey) -> WebhookConfig:
    return _config(key.id)


@router.put("", response_model=WebhookConfig, summary="Set (or clear with null) this key's default webhook URL",
            responses=problem_responses(422, examples={422: ("invalid_callback_url", "url must be an http or https URL, not 'ftp'", "url")}))
def set_key_webhook(body: WebhookUrl, key: CurrentKey) -> WebhookConfig:
    return _config(key.id, url=checked_callback_url(body.url, field="url"), set_url=True)


@router.post("/secret", response_model=WebhookConfig, summary="Replace this key's signing secret with a new one")
def rotate_webhook_secret(key: CurrentKey) -> WebhookConfig:
    return _config(key.id, rotate=True)
