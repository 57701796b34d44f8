"""A job's end of life: DELETE (cancels first when active), retention of finished jobs, and orphaned files.

Files go after the rows that name them are gone: a crash in between leaves orphans, never a row without its file,
and the orphan sweep removes what is left. An upload is content-addressed and may back several assets, so its
file goes only once no asset row names it.
"""

from __future__ import annotations

import logging
import time
import uuid
from datetime import timedelta

from sqlalchemy import delete, or_, select, update
from sqlalchemy.orm import Session

from api import changes
from api.db import session_scope
from api.jobs import state
from api.models import Artifact, Asset, Job, WebhookDelivery, Worker
from api.settings import Settings
from api.storage import Storage, get_storage

log = logging.getLogger("rigforge.lifecycle")
SWEEP_BATCH = 200


def _unused_assets(session: Session, asset_ids: set[uuid.UUID]) -> list[Asset]:
    """Those of `asset_ids` no job uses as its mesh, motion or skeleton."""
    if not asset_ids:
        return []
    used = set(session.scalars(select(Job.mesh_asset_id).where(Job.mesh_asset_id.in_(asset_ids))))
    used |= set(session.scalars(select(Job.motion_asset_id).where(Job.motion_asset_id.in_(asset_ids))))
    used |= set(session.scalars(select(Job.skeleton_asset_id).where(Job.skeleton_asset_id.in_(asset_ids))))
    return list(session.scalars(select(Asset).where(Asset.id.in_(asset_ids - used))))


def _remove_rows(session: Session, job_id: uuid.UUID) -> list[str]:
    """Delete a job's rows (cancelled first when queued or running) and its assets no other job uses.
    Returns the upload locators no asset row names any more. The caller commits."""
    state.cancel(session, job_id)  # a worker still running it stops at its next progress report or heartbeat
    job = session.get(Job, job_id, populate_existing=True)
    if job is None:
        return []
    asset_ids = {a for a in (job.mesh_asset_id, job.motion_asset_id, job.skeleton_asset_id) if a is not None}
    session.execute(update(Job).where(Job.source_job_id == job_id).values(source_job_id=None)
                    .execution_options(synchronize_session=False))
    session.execute(delete(Artifact).where(Artifact.job_id == job_id).execution_options(synchronize_session=False))
    session.execute(update(WebhookDelivery).where(WebhookDelivery.job_id == job_id).values(job_id=None)
                    .execution_options(synchronize_session=False))
    session.execute(delete(Job).where(Job.id == job_id).execution_options(synchronize_session=False))
    session.expunge(job)
    unused = _unused_assets(session, asset_ids)
    locators = {a.path for a in unused}
    for asset in unused:
        session.delete(asset)
    session.flush()
    still_named = set(session.scalars(select(Asset.path).where(Asset.path.in_(locators)))) if locators else set()
    return sorted(locators - still_named)


def delete_job(job_id: uuid.UUID, storage: Storage | None = None) -> None:
    """Remove a job, its artifacts and its uploads no other job uses; a queued or running job is canceled first."""
    with session_scope() as session:
        uploads = _remove_rows(session, job_id)
    changes.publish("job", job_id)
    storage = storage or get_storage()
    storage.delete_job(job_id)
    for locator in uploads:
        storage.delete_upload(locator)


def sweep_retention(settings: Settings, storage: Storage | None = None) -> int:
    """Delete finished jobs older than `retention_days` (none when 0) and old delivery/worker rows. Returns jobs deleted."""
    if not settings.retention_days:
        return 0
    cutoff = state.now() - timedelta(days=settings.retention_days)
    deleted = 0
    while True:
        with session_scope() as session:
            expired = list(session.scalars(select(Job.id).where(Job.status.in_(state.TERMINAL), Job.finished_at < cutoff)
                                           .limit(SWEEP_BATCH)))
        for job_id in expired:
            delete_job(job_id, storage)
        deleted += len(expired)
        if len(expired) < SWEEP_BATCH:
            break
    with session_scope() as session:
        session.execute(delete(WebhookDelivery).where(WebhookDelivery.created_at < cutoff,
                                                      or_(WebhookDelivery.job_id.is_(None), WebhookDelivery.status != "pending")))
        session.execute(delete(Worker).where(Worker.last_seen_at < cutoff))
    if deleted:
        log.info("retention: deleted %d jobs finished before %s", deleted, cutoff.isoformat(timespec="seconds"))
    return deleted


def sweep_orphans(settings: Settings, storage: Storage | None = None) -> tuple[int, int]:
    """Delete uploads no asset names and job outputs with no job row, once older than `orphan_grace_seconds`
    (an upload is kept before its row is written). Returns (uploads, job output folders) deleted."""
    storage = storage or get_storage()
    cutoff = state.now() - timedelta(seconds=settings.orphan_grace_seconds)
    with session_scope() as session:
        named = set(session.scalars(select(Asset.path)))
        jobs = set(session.scalars(select(Job.id)))
    uploads = [locator for locator, modified in storage.uploads() if modified < cutoff and locator not in named]
    outputs = [job_id for job_id, modified in storage.job_outputs() if modified < cutoff and job_id not in jobs]
    with session_scope() as session:  # re-check: a job may have named an upload since
        renamed = set(session.scalars(select(Asset.path).where(Asset.path.in_(uploads)))) if uploads else set()
    uploads = [u for u in uploads if u not in renamed]
    for locator in uploads:
        storage.delete_upload(locator)
    for job_id in outputs:
        storage.delete_job(job_id)
    if uploads or outputs:
        log.info("cleanup: deleted %d orphaned uploads and %d orphaned job outputs", len(uploads), len(outputs))
    return len(uploads), len(outputs)


def sweep_scratch(settings: Settings, storage: Storage | None = None) -> int:
    """Delete this host's scratch entries (staged uploads, job work and input folders) that no live request or job
    can still use: older than a job's hard time limit plus the orphan grace (a killed worker leaves them).
    Returns how many were deleted."""
    storage = storage or get_storage()
    cutoff = time.time() - settings.jobs.time_limit - settings.orphan_grace_seconds
    stale = [entry for entry in storage.scratch.iterdir() if entry.stat().st_mtime < cutoff]
    for entry in stale:
        if entry.is_dir():
            storage.discard(entry)
        else:
            entry.unlink(missing_ok=True)
    if stale:
        log.info("cleanup: deleted %d stale scratch entries", len(stale))
    return len(stale)


def cleanup(settings: Settings) -> None:
    """The periodic cleanup: retention, orphans, stale scratch space."""
    storage = get_storage()
    sweep_retention(settings, storage)
    sweep_orphans(settings, storage)
    sweep_scratch(settings, storage)
