"""Which Celery queue a job goes to: `gpu` for work a GPU speeds up, when a worker consumes that queue; else `cpu`.

Refinement (MLS-MPM in Warp, CUDA when present) and the learned models (torch: skinning `auto`/`learned`, skeleton
`learned`; skeleton `auto` weighs no learned candidates) go to `gpu`. Whether any worker
consumes `gpu` is asked of the workers themselves (Celery's remote control, one broadcast answered within
a second, remembered for PRESENCE_TTL seconds), so a deployment with CPU workers only never strands a job. A job sent
to `gpu` whose worker then leaves waits in that queue until the reconciler re-sends it (requeue_after_seconds),
routed again; a duplicate delivery is harmless (the claim is a compare-and-set).
"""

from __future__ import annotations

import threading
import time
import uuid

from simcore.options import JobOptions

CPU_QUEUE, GPU_QUEUE = "cpu", "gpu"
QUEUES = (CPU_QUEUE, GPU_QUEUE)
PRESENCE_TTL = 30.0
INSPECT_TIMEOUT = 1.0
_LEARNED_SKINNING = {"auto", "learned"}

_lock = threading.Lock()
_seen: tuple[float, bool] = (-PRESENCE_TTL, False)  # (monotonic time asked, a gpu consumer answered)


def wants_gpu(options: JobOptions) -> bool:
    """Refinement, or a skeleton/skinning method that runs a learned model."""
    predicted = options.skeleton == "learned" and (options.stages is None or "skeleton" in options.stages)
    skinned = options.skinning in _LEARNED_SKINNING and (options.stages is None or "skin" in options.stages)
    return options.refine.enabled or predicted or skinned


def gpu_consumer_present() -> bool:
    """Whether a running worker consumes the `gpu` queue (asked at most once per PRESENCE_TTL)."""
    global _seen
    from worker.celery_app import make_celery

    app = make_celery()
    if not app.conf.worker_enable_remote_control:  # filesystem:// has no broadcast; its one worker takes both queues
        return False
    with _lock:
        asked, present = _seen
        if time.monotonic() - asked < PRESENCE_TTL:
            return present
        replies = app.control.inspect(timeout=INSPECT_TIMEOUT).active_queues() or {}
        present = any(q.get("name") == GPU_QUEUE for queues in replies.values() for q in queues or [])
        _seen = (time.monotonic(), present)
        return present


def queue_for(job_id: uuid.UUID) -> str:
    """The queue of job `job_id`, from its options and the workers present."""
    from api.db import session_scope
    from api.models import Job

    with session_scope() as session:
        job = session.get(Job, job_id)
        options = JobOptions.model_validate(job.options) if job is not None else JobOptions()
    return GPU_QUEUE if wants_gpu(options) and gpu_consumer_present() else CPU_QUEUE
