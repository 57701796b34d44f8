"""The embedded filesystem:// broker survives killed idle pool processes without a restart (the old wedge)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

from tests.service_env import service_env
from tests.worker.test_embedded_worker import FAST, REPO, all_finished, children, group, submit_jobs, wait_for


def test_three_idle_pool_processes_killed_in_a_row_and_the_same_worker_still_runs_every_job(tmp_path):
    from api.settings import get_settings
    from worker.embedded import ready_file

    with service_env(tmp_path / "data", **FAST):
        worker = subprocess.Popen([sys.executable, "-m", "cli.main", "worker", "--loglevel", "WARNING"], cwd=REPO,
                                  start_new_session=True)
        try:
            wait_for(lambda: ready_file(get_settings(), worker.pid).exists(), 120)  # a pool lost at start ends the worker
            killed: list[int] = []
            for _ in range(3):  # an idle pool process used to die holding the lock of the pool's shared job pipe
                pool = wait_for(lambda: [p for p in children(worker.pid) if p not in killed], 120)
                os.kill(pool[0], signal.SIGKILL)
                killed.append(pool[0])
            ids = submit_jobs(3)
            rows = wait_for(lambda: all_finished(ids), 120, 0.5)
            assert [j.status for j in rows] == ["succeeded"] * 3, [(j.status, j.error_code) for j in rows]
            assert worker.poll() is None  # no restart was needed
        finally:
            os.killpg(worker.pid, signal.SIGKILL)
            worker.wait(10)
        wait_for(lambda: not group(worker.pid), 20)  # its pool goes with it
