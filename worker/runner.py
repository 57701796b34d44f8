"""Run one claimed attempt of a job: pipeline, heartbeat, progress, cancel, atomic publish."""

from __future__ import annotations

import logging
import threading
import time
import uuid
from pathlib import Path

from api.db import session_scope
from api.jobs import state
from api.models import Job
from api.settings import Settings
from api.storage import Storage, get_storage
from simcore.errors import Canceled, SimcoreError
from simcore.options import JobOptions

log = logging.getLogger("rigforge.worker")
PROGRESS_MIN_INTERVAL = 0.25


class Heartbeat(threading.Thread):
    """Renews the lease and notices when the job was canceled or taken away."""

    def __init__(self, claim: state.Claim, settings: Settings) -> None:
        super().__init__(daemon=True, name=f"heartbeat-{claim.job_id}")
        self.claim, self.settings = claim, settings
        self.lost = threading.Event()
        self._stop = threading.Event()

    def run(self) -> None:
        while not self._stop.wait(self.settings.jobs.heartbeat_seconds):
            try:
                with session_scope() as session:
                    if state.heartbeat(session, self.claim, self.settings.jobs.lease_seconds) != "running":
                        self.lost.set()
                        return
            except Exception:  # noqa: BLE001 - a transient DB error must not kill the job; the lease has slack
                log.exception("heartbeat failed for %s", self.claim.job_id)

    def stop(self) -> None:
        self._stop.set()


class ProgressReporter:
    """Writes stage/progress to the job row (throttled), raising Canceled once the attempt lost the job."""

    def __init__(self, claim: state.Claim, heartbeat: Heartbeat) -> None:
        self.claim, self.heartbeat = claim, heartbeat
        self._last: tuple[str | None, float, float] = (None, -1.0, 0.0)  # stage, progress, monotonic time

    def __call__(self, stage: str, progress: float) -> None:
        last_stage, _, last_time = self._last
        now = time.monotonic()
        if stage == last_stage and now - last_time < PROGRESS_MIN_INTERVAL:
            return
        self._last = (stage, progress, now)
        with session_scope() as session:
            if not state.report_progress(session, self.claim, stage, progress):
                self.heartbeat.lost.set()
        self.check_cancel()

    def check_cancel(self) -> None:
        if self.heartbeat.lost.is_set():
            raise Canceled("the job was canceled or re-assigned")


def execute(job_id: uuid.UUID, settings: Settings, worker_id: str) -> str:
    """Claim and run a job; returns what happened (skipped, succeeded, failed, canceled, lost)."""
    with session_scope() as session:
        claim = state.claim(session, job_id, worker_id, settings.jobs.lease_seconds)
        if claim is None:
            return "skipped"
        job = session.get_one(Job, job_id)  # the claim just updated its row
        mesh, motion, skeleton = job.mesh_asset, job.motion_asset, job.skeleton_asset
        mesh_spec = (mesh.path, mesh.format)
        motion_spec = (motion.path, motion.format, Path(motion.filename).stem) if motion else None
        skeleton_locator = skeleton.path if skeleton else None
        options = JobOptions.model_validate(job.options)
    storage = get_storage()
    work = storage.work_dir(job_id, claim.attempt)
    inputs = storage.scratch_dir(f"inputs-{job_id}-{claim.attempt}")  # fetched inputs stay out of the outputs
    heartbeat = Heartbeat(claim, settings)
    heartbeat.start()
    reporter = ProgressReporter(claim, heartbeat)
    try:
        from simcore.pipeline import PipelineInputs, run_pipeline  # heavy: torch/warp live behind this import

        spec = PipelineInputs(storage.fetch(mesh_spec[0], inputs), mesh_spec[1])
        if motion_spec:
            spec.motion_path, spec.motion_format, spec.motion_name = storage.fetch(motion_spec[0], inputs), *motion_spec[1:]
        if skeleton_locator:
            spec.skeleton_path = storage.fetch(skeleton_locator, inputs)
        result = run_pipeline(spec, options, work, reporter, reporter.check_cancel, settings.budgets)
        heartbeat.stop()
        rows = storage.publish(work, job_id, claim.attempt, sorted(result.artifacts))
        with session_scope() as session:
            return "succeeded" if state.succeed(session, claim, rows, result.report.get("warnings", []),
                                               result.report.get("timings_s")) else "lost"
    except Canceled:
        storage.discard(work)
        return "canceled"
    except SimcoreError as exc:
        return _fail(claim, exc.code, str(exc), storage, work, exc.warnings)
    except Exception as exc:  # noqa: BLE001 - any other failure is recorded on the job, never lost
        from celery.exceptions import SoftTimeLimitExceeded

        if isinstance(exc, SoftTimeLimitExceeded):
            return _fail(claim, "timeout", f"the job ran past its {settings.jobs.soft_time_limit} s limit", storage, work)
        log.exception("job %s failed", job_id)
        return _fail(claim, "internal_error", f"{type(exc).__name__}: {exc}", storage, work)
    finally:
        heartbeat.stop()
        storage.discard(inputs)


def _fail(claim: state.Claim, code: str, message: str, storage: Storage, work: Path,
          warnings: list[dict] | None = None) -> str:
    storage.discard(work)
    with session_scope() as session:
        return "failed" if state.fail(session, claim, code, message, warnings) else "lost"
