"""Server-sent events of jobs: every open stream waits, at no cost, until a change notice of its job wakes it.

On a Redis broker the notices are the pub/sub messages every transition publishes (api.changes): an idle stream
reads nothing, and the streams of one job share one read per change (api.jobs.views). Without notices from other
processes (the embedded default, or while Redis is away) one watcher per API process reads the state of every
watched job in one query every POLL_SECONDS and turns what changed into notices: one query for all streams,
never one loop per stream. Each stream also re-reads its job with every keep-alive, in case a notice was lost.
"""

from __future__ import annotations

import asyncio
import threading
import uuid
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi.concurrency import run_in_threadpool
from sqlalchemy import select

from api import changes
from api.db import session_scope
from api.jobs.state import TERMINAL
from api.jobs.views import job_view
from api.models import Job

POLL_SECONDS = 0.3
KEEPALIVE_SECONDS = 15.0
Moment = tuple[str, str | None, float]


def read_moments(job_ids: list[uuid.UUID]) -> dict[uuid.UUID, Moment]:
    """(status, stage, progress) of each job that exists (blocking; one query)."""
    with session_scope() as session:
        rows = session.execute(select(Job.id, Job.status, Job.stage, Job.progress).where(Job.id.in_(job_ids))).all()
    return {row[0]: (row[1], row[2], row[3]) for row in rows}


class StreamHub:
    """The open event streams of this process, by job."""

    def __init__(self) -> None:
        self._waiting: dict[uuid.UUID, set[tuple[asyncio.AbstractEventLoop, asyncio.Event]]] = {}
        self._lock = threading.Lock()
        self._watchers: dict[asyncio.AbstractEventLoop, asyncio.Task[None]] = {}
        changes.listen(self._on_notice)

    def streams(self) -> int:
        return sum(len(w) for w in self._waiting.values())

    def _on_notice(self, kind: str, ident: str) -> None:
        with self._lock:
            if kind == "reset":
                woken = [w for ws in self._waiting.values() for w in ws]
            elif kind == "job":
                try:
                    woken = list(self._waiting.get(uuid.UUID(ident), ()))
                except ValueError:
                    return
            else:
                return
        for loop, event in woken:
            try:
                loop.call_soon_threadsafe(event.set)
            except RuntimeError:  # that loop is closed: its stream is gone
                pass

    @asynccontextmanager
    async def watch(self, job_id: uuid.UUID) -> AsyncIterator[asyncio.Event]:
        """An event set whenever job `job_id` may have changed, for as long as the block runs."""
        loop, event = asyncio.get_running_loop(), asyncio.Event()
        with self._lock:
            self._waiting.setdefault(job_id, set()).add((loop, event))
        watcher = self._watchers.get(loop)
        if watcher is None or watcher.done():
            self._watchers[loop] = loop.create_task(self._watch_database(loop))
        try:
            yield event
        finally:
            with self._lock:
                waiting = self._waiting.get(job_id)
                if waiting is not None:
                    waiting.discard((loop, event))
                    if not waiting:
                        del self._waiting[job_id]

    def _watched(self, loop: asyncio.AbstractEventLoop) -> list[uuid.UUID]:
        with self._lock:
            return [job_id for job_id, ws in self._waiting.items() if any(w[0] is loop for w in ws)]

    async def _watch_database(self, loop: asyncio.AbstractEventLoop) -> None:
        """While this loop has streams: when notices do not come from every process, find changes in the database."""
        seen: dict[uuid.UUID, Moment | None] = {}
        while watched := self._watched(loop):
            if changes.notices().live():
                seen.clear()  # notices do the work; start afresh if they stop
            else:
                moments = await run_in_threadpool(read_moments, watched)
                for job_id in watched:
                    now = moments.get(job_id)
                    if job_id not in seen or seen[job_id] != now:
                        seen[job_id] = now
                        changes.heard("job", job_id)
                for job_id in set(seen) - set(watched):
                    del seen[job_id]
            await asyncio.sleep(POLL_SECONDS)
        self._watchers.pop(loop, None)


_hub = StreamHub()


async def job_stream(job_id: uuid.UUID, base: str) -> AsyncIterator[str]:
    """`event: job` with the job's JSON at each status, stage or progress change until it ends; keep-alive comments."""
    async with _hub.watch(job_id) as changed:
        last: Moment | None = None
        while True:
            changed.clear()
            view = await job_view(job_id, base)
            if view is None:
                return
            if view.moment != last:
                last = view.moment
                yield f"event: job\ndata: {view.body.decode()}\n\n"
                if view.status in TERMINAL:
                    return
            try:
                await asyncio.wait_for(changed.wait(), KEEPALIVE_SECONDS)
            except TimeoutError:
                yield ": keep-alive\n\n"


def open_streams() -> int:
    """Event streams open in this process."""
    return _hub.streams()
