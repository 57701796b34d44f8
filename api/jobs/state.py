"""The job state machine. Every transition is a compare-and-set UPDATE, so concurrent workers, the
reconciler and the API can never move one job twice; `attempts` is the fencing token of a run. Every transition
that changes what a client sees publishes a change notice after its commit (api.changes).

queued → running → succeeded | failed | canceled;  queued → canceled;  running → queued (lease lost, or the
process running it died).
"""

from __future__ import annotations

import os
import socket
import uuid
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta

from sqlalchemy import ColumnElement, select, update
from sqlalchemy.orm import Session

from api import changes
from api.db import rowcount
from api.models import Artifact, Job
from api.webhooks import outbox

TERMINAL = ("succeeded", "failed", "canceled")


def now() -> datetime:
    return datetime.now(UTC)


@dataclass(frozen=True)
class Claim:
    """A worker's right to run one attempt of a job."""

    job_id: uuid.UUID
    attempt: int
    worker_id: str


def claim(session: Session, job_id: uuid.UUID, worker_id: str, lease_seconds: float) -> Claim | None:
    """queued → running, attempts+1. None if another delivery got there first or the job is not queued."""
    job = session.get(Job, job_id)
    if job is None or job.status != "queued":
        return None
    attempt = job.attempts + 1
    t = now()
    result = session.execute(
        update(Job)
        .where(Job.id == job_id, Job.status == "queued", Job.attempts == job.attempts)
        .values(status="running", attempts=attempt, worker_id=worker_id, lease_expires_at=t + timedelta(seconds=lease_seconds),
                started_at=t, stage="starting", progress=0.0, error_code=None, error_message=None, warnings=[])
        .execution_options(synchronize_session=False)
    )
    session.commit()
    if rowcount(result) != 1:
        return None
    changes.publish("job", job_id)
    return Claim(job_id, attempt, worker_id)


def _running(claim_: Claim):  # noqa: ANN202
    return (Job.id == claim_.job_id, Job.status == "running", Job.attempts == claim_.attempt)


def heartbeat(session: Session, claim_: Claim, lease_seconds: float) -> str | None:
    """Extend the lease. Returns the job's status, or None when this attempt no longer owns the job."""
    result = session.execute(
        update(Job).where(*_running(claim_)).values(lease_expires_at=now() + timedelta(seconds=lease_seconds))
        .execution_options(synchronize_session=False)
    )
    session.commit()
    if rowcount(result) == 1:
        return "running"
    job = session.get(Job, claim_.job_id)
    session.refresh(job) if job is not None else None
    return None if job is None or job.attempts != claim_.attempt else job.status


def report_progress(session: Session, claim_: Claim, stage: str, progress: float) -> bool:
    """Record stage/progress; False when this attempt lost the job (canceled, re-queued)."""
    result = session.execute(
        update(Job).where(*_running(claim_)).values(stage=stage, progress=round(float(progress), 4))
        .execution_options(synchronize_session=False)
    )
    session.commit()
    if rowcount(result) != 1:
        return False
    changes.publish("job", claim_.job_id)
    return True


def succeed(session: Session, claim_: Claim, artifacts: list[dict], warnings: list[dict] | None = None,
            timings: dict[str, float] | None = None) -> bool:
    """running → succeeded with its artifact rows, warnings, stage timings (seconds) and webhook event, in one
    transaction. False if this attempt lost the job."""
    result = session.execute(
        update(Job).where(*_running(claim_))
        .values(status="succeeded", stage="done", progress=1.0, finished_at=now(), lease_expires_at=None,
                warnings=warnings or [], timings=timings)
        .execution_options(synchronize_session=False)
    )
    if rowcount(result) != 1:
        session.rollback()
        return False
    session.add_all(Artifact(job_id=claim_.job_id, **a) for a in artifacts)
    outbox.record(session, claim_.job_id, "job.succeeded")
    session.commit()
    changes.publish("job", claim_.job_id)
    return True


def fail(session: Session, claim_: Claim, code: str, message: str, warnings: list[dict] | None = None) -> bool:
    """running → failed with a stable code, a human message, the warnings recorded up to the failure and the webhook event."""
    result = session.execute(
        update(Job).where(*_running(claim_))
        .values(status="failed", finished_at=now(), lease_expires_at=None, error_code=code, error_message=message[:4000],
                warnings=warnings or [])
        .execution_options(synchronize_session=False)
    )
    if rowcount(result) != 1:
        session.rollback()
        return False
    outbox.record(session, claim_.job_id, "job.failed")
    session.commit()
    changes.publish("job", claim_.job_id)
    return True


def cancel(session: Session, job_id: uuid.UUID) -> bool:
    """queued|running → canceled. A running worker notices at its next stage boundary or heartbeat."""
    result = session.execute(
        update(Job).where(Job.id == job_id, Job.status.in_(("queued", "running")))
        .values(status="canceled", finished_at=now(), lease_expires_at=None, error_code="canceled", error_message="canceled by the user")
        .execution_options(synchronize_session=False)
    )
    if rowcount(result) != 1:
        session.rollback()
        return False
    outbox.record(session, job_id, "job.canceled")
    session.commit()
    changes.publish("job", job_id)
    return True


def mark_enqueued(session: Session, job_id: uuid.UUID) -> None:
    session.execute(update(Job).where(Job.id == job_id).values(enqueued_at=now()).execution_options(synchronize_session=False))
    session.commit()


def _lost_values(attempts: int, max_attempts: int, t: datetime) -> dict:
    """What a running attempt that was lost becomes: queued again, or failed past max_attempts."""
    if attempts >= max_attempts:
        return dict(status="failed", finished_at=t, lease_expires_at=None, error_code="worker_lost",
                    error_message=f"the worker running this job stopped responding {attempts} times")
    return dict(status="queued", stage="requeued", lease_expires_at=None, worker_id=None, enqueued_at=t)


def worker_id(pid: int | None = None) -> str:
    """The id a claim records for process `pid` (default this one) on this host: `host:pid`."""
    return f"{socket.gethostname()}:{os.getpid() if pid is None else pid}"


def _release(session: Session, job_id: uuid.UUID, attempts: int, max_attempts: int, t: datetime, *guards: ColumnElement[bool]) -> str | None:
    """Compare-and-set a lost attempt (`attempts`, still running, and `guards`) to queued, or to failed past max_attempts
    with its webhook event; uncommitted. Returns the new status, or None when the job is no longer that attempt."""
    values = _lost_values(attempts, max_attempts, t)
    result = session.execute(
        update(Job).where(Job.id == job_id, Job.status == "running", Job.attempts == attempts, *guards)
        .values(**values).execution_options(synchronize_session=False)
    )
    if rowcount(result) != 1:
        return None
    if values["status"] == "failed":
        outbox.record(session, job_id, "job.failed")
    return str(values["status"])


def release_lost(session: Session, job_id: uuid.UUID, worker_id: str, max_attempts: int) -> str | None:
    """The process `worker_id` died running the job: re-queue it now, without waiting for its lease (or fail it past
    max_attempts). Returns the new status, or None when that process no longer held the job."""
    job = session.get(Job, job_id)
    status = None if job is None else _release(session, job_id, job.attempts, max_attempts, now(), Job.worker_id == worker_id)
    if status is None:
        session.rollback()
        return None
    session.commit()
    changes.publish("job", job_id)
    return status


def reconcile(session: Session, max_attempts: int, requeue_after_seconds: float) -> tuple[list[uuid.UUID], list[uuid.UUID]]:
    """Recover lost work. Returns (job ids to (re-)enqueue, job ids failed as worker_lost).

    A running job whose lease expired goes back to queued (or fails past max_attempts); a queued job
    not picked up for `requeue_after_seconds` is re-sent (a duplicate delivery is harmless: claim is a CAS).
    """
    t = now()
    requeue: list[uuid.UUID] = []
    lost: list[uuid.UUID] = []
    expired = session.execute(select(Job.id, Job.attempts).where(Job.status == "running", Job.lease_expires_at < t)).all()
    for job_id, attempts in expired:
        status = _release(session, job_id, attempts, max_attempts, t, Job.lease_expires_at < t)
        if status is not None:
            (lost if status == "failed" else requeue).append(job_id)
    moved = list(requeue)
    stale = t - timedelta(seconds=requeue_after_seconds)
    for (job_id,) in session.execute(select(Job.id).where(Job.status == "queued", Job.enqueued_at < stale)).all():
        session.execute(update(Job).where(Job.id == job_id, Job.status == "queued").values(enqueued_at=t)
                        .execution_options(synchronize_session=False))
        requeue.append(job_id)
    session.commit()
    for job_id in (*moved, *lost):  # a job only re-sent changed nothing a client sees
        changes.publish("job", job_id)
    return requeue, lost
