"""A real worker applies the memory cap in its pool process; a job that cannot fit fails with too_large, the
pool process lives on and runs the next job."""

from __future__ import annotations

import sys
from pathlib import Path

from tests.service_env import service_env
from tests.worker.test_embedded_worker import FAST, all_finished, children, submit_jobs, wait_for

CAP_MB = 700


def data_limit(pid: int) -> int | None:
    """The soft RLIMIT_DATA of a process in bytes (None: unlimited), from /proc."""
    for line in Path(f"/proc/{pid}/limits").read_text().splitlines():
        if line.startswith("Max data size"):
            soft = line.split()[3]
            return None if soft == "unlimited" else int(soft)
    raise AssertionError("no data size limit line")


def test_the_pool_process_is_capped_and_a_job_over_the_cap_fails_with_too_large_without_killing_it(tmp_path):
    from api.settings import get_settings
    from worker.embedded import EmbeddedWorker

    with service_env(tmp_path / "data", **FAST, budgets__worker_memory_mb=str(CAP_MB)):
        worker = EmbeddedWorker(get_settings(), [sys.executable, "-m", "cli.main", "worker", "--loglevel", "WARNING"])
        worker.start()
        try:
            leader = wait_for(lambda: worker.proc, 60)
            pool = wait_for(lambda: children(leader.pid), 120)
            wait_for(lambda: data_limit(pool[0]) is not None, 30)
            assert data_limit(pool[0]) == CAP_MB * 2**20
            heavy = submit_jobs(1, stages=["skeleton"])
            light = submit_jobs(1)
            rows = wait_for(lambda: all_finished(heavy + light), 240, 1)
            assert (rows[0].status, rows[0].error_code) == ("failed", "too_large"), rows[0].error_message
            assert "RIGFORGE_BUDGETS__WORKER_MEMORY_MB" in rows[0].error_message
            assert rows[1].status == "succeeded"
            assert children(leader.pid) == pool  # the same pool process ran both
        finally:
            worker.stop(grace=5)
