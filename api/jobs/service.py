"""Job use cases, free of HTTP: create (idempotent), look up, list, serialise."""

from __future__ import annotations

import base64
import hashlib
import json
import uuid
from datetime import datetime

from sqlalchemy import or_, select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from api.jobs.schemas import ArtifactOut, InputFile, JobError, JobOut, JobWarning
from api.models import Asset, Job
from api.settings import get_settings
from api.signed_urls import ZIP_NAME, signed_path
from api.storage import StoredFile, get_storage
from api.webhooks.schemas import delivery_log
from simcore.options import JobOptions


class IdempotencyConflict(Exception):
    """The Idempotency-Key was used before with a different request."""


def request_hash(mesh_sha: str, motion_sha: str | None, options: JobOptions, skeleton_sha: str | None = None,
                 source_job_id: uuid.UUID | None = None, callback_url: str | None = None) -> str:
    request = {"mesh": mesh_sha, "motion": motion_sha, "options": options.model_dump(mode="json")}
    if skeleton_sha or source_job_id:  # absent for plain jobs, so their hashes stay as they were
        request.update(skeleton=skeleton_sha, source_job=str(source_job_id) if source_job_id else None)
    if callback_url:
        request.update(callback_url=callback_url)
    canonical = json.dumps(request, sort_keys=True)
    return hashlib.sha256(canonical.encode()).hexdigest()


def _asset(session: Session, owner_id: uuid.UUID, stored: StoredFile, filename: str, fmt: str) -> Asset:
    asset = Asset(owner_id=owner_id, filename=filename[:255] or "upload", format=fmt, size=stored.size, sha256=stored.sha256, path=stored.locator)
    session.add(asset)
    return asset


def _earlier(session: Session, owner_id: uuid.UUID, idempotency_key: str, digest: str) -> Job | None:
    """The job an earlier request made with this key; IdempotencyConflict when that request differed."""
    earlier = session.scalar(select(Job).where(Job.owner_id == owner_id, Job.idempotency_key == idempotency_key))
    if earlier is not None and earlier.request_hash != digest:
        raise IdempotencyConflict
    return earlier


def create_job(
    session: Session, *, owner_id: uuid.UUID, mesh: tuple[StoredFile, str, str], motion: tuple[StoredFile, str, str] | None,
    options: JobOptions, idempotency_key: str | None, skeleton: tuple[StoredFile, str, str] | None = None,
    source_job_id: uuid.UUID | None = None, callback_url: str | None = None,
) -> tuple[Job, bool]:
    """Record the assets and a queued job; returns (job, created). Same key + same request → the earlier job,
    also when the two requests race (the loser of the unique constraint answers with the winner's job)."""
    digest = request_hash(mesh[0].sha256, motion[0].sha256 if motion else None, options,
                          skeleton[0].sha256 if skeleton else None, source_job_id, callback_url)
    if idempotency_key and (earlier := _earlier(session, owner_id, idempotency_key, digest)) is not None:
        return earlier, False
    mesh_asset = _asset(session, owner_id, *mesh)
    motion_asset = _asset(session, owner_id, *motion) if motion else None
    skeleton_asset = _asset(session, owner_id, *skeleton) if skeleton else None
    session.flush()
    job = Job(owner_id=owner_id, options=options.model_dump(mode="json"), mesh_asset_id=mesh_asset.id,
              motion_asset_id=motion_asset.id if motion_asset else None,
              skeleton_asset_id=skeleton_asset.id if skeleton_asset else None, source_job_id=source_job_id,
              idempotency_key=idempotency_key, request_hash=digest, callback_url=callback_url)
    session.add(job)
    try:
        session.commit()
    except IntegrityError:
        session.rollback()
        if not idempotency_key or (earlier := _earlier(session, owner_id, idempotency_key, digest)) is None:
            raise
        return earlier, False
    return job, True


def rerun_job(session: Session, *, job: Job) -> Job:
    """A new queued job on the same inputs (mesh, motion, skeleton file) and options as `job`."""
    again = Job(owner_id=job.owner_id, options=dict(job.options), mesh_asset_id=job.mesh_asset_id,
                motion_asset_id=job.motion_asset_id, skeleton_asset_id=job.skeleton_asset_id,
                source_job_id=job.source_job_id, idempotency_key=None, request_hash=job.request_hash,
                callback_url=job.callback_url)
    session.add(again)
    session.commit()
    return again



def owned_job(session: Session, *, job_id: uuid.UUID, owner_id: uuid.UUID) -> Job | None:
    """The job when it exists and belongs to this key (another key's job is indistinguishable from none)."""
    job = session.get(Job, job_id)
    return job if job is not None and job.owner_id == owner_id else None


def encode_cursor(job: Job) -> str:
    return base64.urlsafe_b64encode(f"{job.created_at.isoformat()}|{job.id}".encode()).decode()


def decode_cursor(cursor: str) -> tuple[datetime, uuid.UUID]:
    """Raises ValueError on a malformed cursor."""
    created, _, job_id = base64.urlsafe_b64decode(cursor.encode()).decode().partition("|")
    return datetime.fromisoformat(created), uuid.UUID(job_id)


def list_jobs(session: Session, *, owner_id: uuid.UUID, status: str | None, limit: int, cursor: str | None) -> tuple[list[Job], str | None]:
    """Newest first, keyset-paginated on (created_at, id)."""
    query = select(Job).where(Job.owner_id == owner_id)
    if status:
        query = query.where(Job.status == status)
    if cursor:
        created, job_id = decode_cursor(cursor)
        query = query.where(or_(Job.created_at < created, (Job.created_at == created) & (Job.id < job_id)))
    rows = list(session.scalars(query.order_by(Job.created_at.desc(), Job.id.desc()).limit(limit + 1)))
    return rows[:limit], encode_cursor(rows[limit - 1]) if len(rows) > limit else None


def _input(asset: Asset | None) -> InputFile | None:
    return None if asset is None else InputFile(filename=asset.filename, format=asset.format, size=asset.size, sha256=asset.sha256)


def to_schema(job: Job, base_url: str) -> JobOut:
    """The public view of a job; artifact URLs are absolute API paths."""
    error = JobError(code=job.error_code, message=job.error_message or "") if job.error_code and job.status != "succeeded" else None
    storage, seconds = get_storage(), get_settings().download_url_seconds
    artifacts = [
        ArtifactOut(name=a.name, media_type=a.media_type, size=a.size, sha256=a.sha256, url=f"{base_url}/api/v1/jobs/{job.id}/artifacts/{a.name}",
                    download_url=storage.presigned_url(a.path, a.name, a.media_type, seconds) or base_url + signed_path(job.id, a.name))
        for a in job.artifacts
    ]
    return JobOut(id=job.id, status=job.status, stage=job.stage, progress=job.progress, created_at=job.created_at, started_at=job.started_at,
                  finished_at=job.finished_at, options=job.options, attempts=job.attempts, mesh=_input(job.mesh_asset),
                  motion=_input(job.motion_asset), skeleton=_input(job.skeleton_asset), source_job_id=job.source_job_id,
                  error=error,
                  warnings=[JobWarning.model_validate(w) for w in job.warnings or []], artifacts=artifacts,
                  callback_url=job.callback_url, webhooks=delivery_log(job.deliveries),
                  download_all_url=base_url + signed_path(job.id, ZIP_NAME) if artifacts else None)
