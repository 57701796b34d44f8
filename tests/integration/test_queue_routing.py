"""Named queues on Redis with real worker processes: GPU work goes to `gpu` only while a worker consumes it, so a
deployment with CPU workers alone runs every job; the compose healthcheck's `celery inspect ping` answers."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys

import pytest

from simcore.options import JobOptions
from tests.integration.conftest import REPO, wait_for
from tests.service_env import service_env

pytestmark = pytest.mark.integration
ROUTING_DB = 11


def _worker(env: dict, queues: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "cli.main", "worker", "--loglevel", "WARNING", "--queues", queues], cwd=REPO,
                            env={**os.environ, **env}, start_new_session=True)


def _stop(proc: subprocess.Popen) -> None:
    os.killpg(proc.pid, signal.SIGTERM)
    proc.wait(30)


def test_wants_gpu_for_refinement_and_learned_models_only():
    from worker.routing import wants_gpu

    assert wants_gpu(JobOptions())  # auto may run the learned models
    assert wants_gpu(JobOptions(skeleton="keep", skinning="geodesic", refine={"enabled": True}))
    assert not wants_gpu(JobOptions(skeleton="geometric", skinning="geodesic"))
    assert not wants_gpu(JobOptions(skeleton="auto", skinning="heat"))  # auto's skeleton candidates are all geometric
    assert wants_gpu(JobOptions(skeleton="learned", skinning="heat"))
    assert not wants_gpu(JobOptions(stages=[]))  # ingest only


def test_gpu_jobs_go_to_the_gpu_queue_only_while_a_worker_consumes_it(tmp_path, pg_url, redis_url, monkeypatch):
    broker = redis_url.rsplit("/", 1)[0] + f"/{ROUTING_DB}"  # its own database: no other test's workers answer here
    with service_env(tmp_path / "data", database_url=pg_url, broker_url=broker):
        from worker import routing

        env = {k: v for k, v in os.environ.items() if k.startswith("RIGFORGE_")}
        monkeypatch.setattr(routing, "PRESENCE_TTL", 0.0)  # ask the workers every time
        assert not routing.gpu_consumer_present()  # no worker: GPU work goes to `cpu`
        gpu = _worker(env, "gpu")
        try:
            wait_for(routing.gpu_consumer_present, 90, 0.5)
            ping = ["-m", "celery", "--app", "worker.tasks", "inspect", "ping", "--timeout", "5",
                    "--destination", f"rigforge-{gpu.pid}@{socket.gethostname()}"]  # the compose healthcheck
            assert subprocess.run([sys.executable, *ping], cwd=REPO, env={**os.environ, **env}, capture_output=True).returncode == 0
        finally:
            _stop(gpu)
        assert not routing.gpu_consumer_present()
