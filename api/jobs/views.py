"""A job's public JSON, as `GET /api/v1/jobs/{id}` and its event stream serve it, read once per change of the job.

While change notices from every process reach this one (api.changes on a Redis broker) a job's JSON is kept in
memory until its next change notice, at most `job_cache_seconds`: a status poll then costs no database round-trip.
Without them (the embedded default) every poll reads the database. Either way, concurrent readers of one job in
this process share one read, unless the job changed after that read began.
Signed download links in a kept answer are at most `job_cache_seconds` older than fresh ones (and the ETag leaves
them out).
"""

from __future__ import annotations

import asyncio
import uuid
from dataclasses import dataclass
from functools import cached_property, partial

from fastapi.concurrency import run_in_threadpool

from api import changes
from api.db import session_scope
from api.errors import Problem
from api.http_cache import entity_tag, gzipped
from api.jobs import service
from api.models import ApiKey, Job
from api.notice_cache import NoticeCache
from api.settings import get_settings

# signed download URLs change with their expiry, not with the job: the ETag leaves them out
VOLATILE = {"artifacts": {"__all__": {"download_url"}}, "download_all_url": True}


@dataclass(frozen=True)
class JobView:
    """One rendering of a job: its JSON body, ETag, owner and the fields an event stream reports changes of."""

    base: str
    owner_id: uuid.UUID
    body: bytes
    etag: str
    status: str
    stage: str | None
    progress: float

    @property
    def moment(self) -> tuple[str, str | None, float]:
        return self.status, self.stage, self.progress

    @cached_property
    def body_gzip(self) -> bytes:
        """The body gzipped, once per view."""
        return gzipped(self.body)


def render(job: Job, base: str) -> JobView:
    """The view of `job` (its relationships loaded) with absolute URLs under `base`."""
    body, etag = entity_tag(service.to_schema(job, base), exclude=VOLATILE)
    return JobView(base, job.owner_id, body, etag, job.status, job.stage, job.progress)


def read_view(job_id: uuid.UUID, base: str) -> JobView | None:
    """From the database (blocking)."""
    with session_scope() as session:
        job = session.get(Job, job_id)
        return None if job is None else render(job, base)


_views: NoticeCache[uuid.UUID, JobView] = NoticeCache(0)


def _on_notice(kind: str, ident: str) -> None:
    if kind == "reset":
        _views.clear()
    elif kind == "job":
        try:
            _views.drop(uuid.UUID(ident))
        except ValueError:
            pass


changes.listen(_on_notice)


def view_cache() -> NoticeCache[uuid.UUID, JobView]:
    """This process's kept views, with the configured time-to-live."""
    _views.ttl = get_settings().job_cache_seconds
    return _views


@dataclass
class _Read:
    loop: asyncio.AbstractEventLoop
    base: str
    token: int
    task: asyncio.Task[JobView | None]


_reads: dict[uuid.UUID, _Read] = {}  # reads in flight, touched only from event loops


def _caching() -> bool:
    notices = changes.notices()
    notices.start()
    return notices.live()


def _forget(job_id: uuid.UUID, read: _Read, _task: object) -> None:
    if _reads.get(job_id) is read:
        del _reads[job_id]


async def job_view(job_id: uuid.UUID, base: str) -> JobView | None:
    """The job's current view (None when there is no such job): kept, shared with a concurrent read, or read now."""
    cache = view_cache()
    caching = _caching()
    if caching and (kept := cache.get(job_id)) is not None and kept.base == base:
        return kept
    loop = asyncio.get_running_loop()
    read = _reads.get(job_id)
    if read is None or read.loop is not loop or read.base != base or not cache.unchanged_since(job_id, read.token):
        token = cache.token()

        async def fetch() -> JobView | None:
            view = await run_in_threadpool(read_view, job_id, base)
            if view is not None and caching:
                cache.put(job_id, view, token)
            return view

        read = _Read(loop, base, token, loop.create_task(fetch()))
        _reads[job_id] = read
        read.task.add_done_callback(partial(_forget, job_id, read))
    return await asyncio.shield(read.task)  # a reader that goes away leaves the read to the others


async def owned_view(job_id: uuid.UUID, key: ApiKey, base: str) -> JobView:
    """The caller's job or 404 (another key's job answers exactly like a missing one)."""
    view = await job_view(job_id, base)
    if view is None or view.owner_id != key.id:
        raise Problem(404, "job_not_found", f"no job {job_id}")
    return view
