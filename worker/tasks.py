"""Celery tasks: thin wrappers that hand a job id to the runner."""

from __future__ import annotations

import os
import uuid

from celery.signals import celeryd_after_setup, setup_logging, worker_process_init, worker_ready, worker_shutdown

from api.jobs.state import worker_id
from api.log_format import configure, job_context
from api.settings import get_settings
from worker.celery_app import TASK_NAME, make_celery
from worker.maintenance import Maintenance
from worker.reconciler import Reconciler
from worker.runner import execute

app = make_celery()
_reconciler: Reconciler | None = None
_maintenance: Maintenance | None = None
_pool_size = 1  # this worker's pool processes (its concurrency), known to the children it forks
_inherited_pools: list[object] = []  # in a pool process: the main process's connection pools, forked with it


@app.task(name=TASK_NAME, ignore_result=True, Request="worker.reconciler:LostJobRequest")  # re-queues a killed job at once
def run_job(job_id: str) -> str:
    """Run job `job_id` if this delivery wins the claim."""
    with job_context(job_id):
        return execute(uuid.UUID(job_id), get_settings(), worker_id())


@setup_logging.connect
def _configure_logging(loglevel: str | None = None, **_: object) -> None:
    """Our log format (RIGFORGE_LOG_FORMAT) instead of Celery's."""
    configure(get_settings(), loglevel or "INFO")


@celeryd_after_setup.connect
def _setup_main_process(instance: object, **_: object) -> None:
    """Before the pool starts: note its size, and fork its processes only between SQLite transactions."""
    global _pool_size
    from api.db import get_engine
    from worker.fork_guard import guard_forks

    _pool_size = int(getattr(instance, "concurrency", 1) or 1)
    if get_engine().dialect.name == "sqlite":
        guard_forks(get_engine())


@worker_process_init.connect
def _init_pool_process(**_: object) -> None:
    """A new pool process: its own database connections, and its share of memory (a job past it fails with
    out_of_memory, the process lives)."""
    from api.db import get_engine
    from simcore.budgets import apply_memory_cap

    if get_engine.cache_info().currsize:  # the pooled connections forked with us are the main process's: two
        engine = get_engine()  # processes on one connection corrupt both, so this process gets a pool of its own
        _inherited_pools.append(engine.pool)  # kept, never closed: closing a forked SQLite handle or socket acts
        engine.pool = engine.pool.recreate()  # on the main process's database locks and sessions too
    apply_memory_cap(get_settings().budgets.memory_cap_bytes(_pool_size))


@worker_ready.connect
def _start_reconciler(sender: object = None, **_: object) -> None:
    global _reconciler, _maintenance
    from worker.embedded import ready_file

    mark_ready = ready_file(get_settings(), os.getpid()).touch  # tells a supervising `serve` this worker consumes
    hub = getattr(sender, "hub", None)
    if hub is None:
        mark_ready()
    else:  # worker_ready fires before Celery checks its pool started: a pool process lost in between ends the worker,
        hub.call_soon(mark_ready)  # so readiness is told from inside the event loop, which runs after that check
    _reconciler = Reconciler(get_settings())
    _reconciler.start()
    concurrency = int(getattr(getattr(sender, "controller", None), "concurrency", 1) or 1)
    _maintenance = Maintenance(get_settings(), worker_id(), concurrency)
    _maintenance.start()


@worker_shutdown.connect
def _stop_reconciler(**_: object) -> None:
    if _reconciler is not None:
        _reconciler.stopped.set()
    if _maintenance is not None:
        _maintenance.stop()
