"""Per-key quotas on submissions: jobs queued or running at once, jobs per hour, bytes kept.

A key's own limits (api_keys.max_*) override the service-wide defaults (RIGFORGE_QUOTAS__*); 0 or less means
unlimited. Over the job limits the API answers 429 with Retry-After; over storage, 429 without a time (it frees
only when jobs are deleted or expire), both as problem+json naming the quota.
"""

from __future__ import annotations

import math
import uuid
from datetime import timedelta

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from api.db import session_scope
from api.errors import Problem
from api.jobs.state import now
from api.metrics import QUOTA_REFUSED
from api.models import ApiKey, Artifact, Asset, Job
from api.settings import QuotaSettings

HOUR = timedelta(hours=1)
CONCURRENT_RETRY_SECONDS = 30  # a job slot frees when one finishes: no exact time to give


def storage_bytes(session: Session, owner_id: uuid.UUID) -> int:
    """Bytes kept for a key: its distinct uploads (by content hash) and every artifact of its jobs."""
    uploads = select(Asset.sha256, Asset.size).where(Asset.owner_id == owner_id).distinct().subquery()
    upload_bytes = session.scalar(select(func.coalesce(func.sum(uploads.c.size), 0)))
    artifact_bytes = session.scalar(select(func.coalesce(func.sum(Artifact.size), 0)).join(Job, Job.id == Artifact.job_id)
                                    .where(Job.owner_id == owner_id))
    return int(upload_bytes or 0) + int(artifact_bytes or 0)


def _limit(own: int | None, default: float) -> float:
    value = own if own is not None else default
    return value if value > 0 else math.inf


def check_submit(key: ApiKey, defaults: QuotaSettings, content_length: str | None) -> None:
    """Raise 429 problem+json when one more job, whose request declares `content_length` bytes, would pass one of
    the key's quotas."""
    incoming_bytes = int(content_length) if content_length and content_length.isdigit() else 0
    with session_scope() as session:
        row = session.get(ApiKey, key.id) or key  # the limits as stored now: `key` may come from the auth cache
        concurrent = _limit(row.max_concurrent_jobs, defaults.concurrent_jobs)
        hourly = _limit(row.max_jobs_per_hour, defaults.jobs_per_hour)
        storage = _limit(row.max_storage_bytes, defaults.storage_mb * 1024 * 1024)
        if concurrent < math.inf:
            active = session.scalar(select(func.count()).select_from(Job)
                                    .where(Job.owner_id == key.id, Job.status.in_(("queued", "running")))) or 0
            if active >= concurrent:
                QUOTA_REFUSED.labels("concurrent_jobs").inc()
                raise Problem(429, "quota_concurrent_jobs", f"this key has {active} jobs queued or running, its limit is "
                              f"{concurrent:g}; wait for one to finish", headers={"Retry-After": str(CONCURRENT_RETRY_SECONDS)})
        if hourly < math.inf:
            since = now() - HOUR
            recent = list(session.scalars(select(Job.created_at).where(Job.owner_id == key.id, Job.created_at > since)
                                          .order_by(Job.created_at.desc()).limit(int(hourly))))
            if len(recent) >= hourly:
                QUOTA_REFUSED.labels("jobs_per_hour").inc()
                wait = max(1, math.ceil((recent[-1] + HOUR - now()).total_seconds()))
                raise Problem(429, "quota_jobs_per_hour", f"this key submitted {len(recent)} jobs in the last hour, its limit "
                              f"is {hourly:g}", headers={"Retry-After": str(wait)})
        if storage < math.inf:
            used = storage_bytes(session, key.id)
            if used + incoming_bytes > storage:
                QUOTA_REFUSED.labels("storage").inc()
                raise Problem(429, "quota_storage", f"this key keeps {used / 2**20:.1f} MB and the upload adds up to "
                              f"{incoming_bytes / 2**20:.1f} MB, past its {storage / 2**20:g} MB limit; delete jobs to free space")
