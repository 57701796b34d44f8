"""docker-compose.yml cannot run here (no daemon, no registry): Compose itself validates it (Debian's docker-compose,
which `make install-test` installs), and its structure is checked: commands the CLI really has, migrations run once
before anything that uses the database, a healthcheck and a restart policy on every long-running service."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from cli.main import app

REPO = Path(__file__).resolve().parents[1]
COMPOSE = REPO / "docker-compose.yml"
ONE_SHOT = {"migrate"}


def services() -> dict[str, dict]:
    return yaml.safe_load(COMPOSE.read_text())["services"]


def compose(*args: str) -> subprocess.CompletedProcess:
    if not shutil.which("docker-compose"):
        message = "docker-compose is not installed (make install-test installs Debian's)"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    return subprocess.run(["docker-compose", "--project-directory", str(REPO), "-f", str(COMPOSE), *args],
                          capture_output=True, text=True, timeout=60)


def test_compose_validates_the_file_with_every_profile():
    for profile in ([], ["--profile", "gpu"]):
        result = compose(*profile, "config", "-q")
        assert result.returncode == 0, result.stderr
    listed = compose("--profile", "gpu", "config", "--services").stdout.split()
    assert {"migrate", "api", "proxy", "worker", "worker-gpu", "redis", "postgres"} == set(listed)


def test_compose_names_real_rigforge_commands_and_flags():
    runner = CliRunner()
    for name, service in services().items():
        command = service.get("command", [])
        if not command or command[0] != "rigforge":
            continue
        result = runner.invoke(app, [command[1], "--help"])
        assert result.exit_code == 0, (name, result.output)
        for flag in (c for c in command[2:] if c.startswith("--")):
            assert flag in result.output, (name, flag)


def test_migrations_run_once_before_the_api_and_workers():
    svc = services()
    assert svc["migrate"]["command"] == ["rigforge", "migrate"] and svc["migrate"]["restart"] == "no"
    for name in ("api", "worker", "worker-gpu"):
        assert svc[name]["depends_on"]["migrate"] == {"condition": "service_completed_successfully"}, name
    assert "--no-migrate" in svc["api"]["command"]  # replicas never race the one-shot migration


def test_every_long_running_service_has_a_healthcheck_and_restarts():
    for name, service in services().items():
        if name in ONE_SHOT:
            continue
        assert service.get("healthcheck", {}).get("test"), name
        assert service.get("restart") == "unless-stopped", name
    assert "/readyz" in " ".join(services()["api"]["healthcheck"]["test"])
    assert "inspect ping" in " ".join(services()["worker"]["healthcheck"]["test"])


def test_api_replicas_sit_behind_one_proxy_port_and_workers_take_named_queues():
    svc = services()
    assert "ports" not in svc["api"] and svc["api"]["deploy"]["replicas"] >= 2
    assert svc["proxy"]["ports"] == ["8000:8000"] and "api:8000" in svc["proxy"]["command"]
    queue = {name: svc[name]["command"][svc[name]["command"].index("--queues") + 1] for name in ("worker", "worker-gpu")}
    assert queue == {"worker": "cpu", "worker-gpu": "gpu"}
    assert svc["worker-gpu"]["profiles"] == ["gpu"]
    assert "cu" in svc["worker-gpu"]["build"]["args"]["TORCH_INDEX"] and svc["worker"]["build"]["args"]["TORCH_INDEX"].endswith("/cpu")
    env = svc["api"]["environment"]
    assert env["RIGFORGE_BROKER_URL"].startswith("redis://") and env["RIGFORGE_DATABASE_URL"].startswith("postgresql+psycopg://")
