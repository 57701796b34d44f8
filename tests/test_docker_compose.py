"""docker-compose.yml cannot run here; check it parses and names commands the CLI really has."""

from __future__ import annotations

from pathlib import Path

import yaml
from typer.testing import CliRunner

from cli.main import app

REPO = Path(__file__).resolve().parents[1]


def test_compose_names_real_rigforge_commands_and_the_scaled_services():
    compose = yaml.safe_load((REPO / "docker-compose.yml").read_text())
    services = compose["services"]
    assert {"api", "worker", "redis", "postgres"} <= set(services)
    assert "rigforge-data" in compose["volumes"]
    runner = CliRunner()
    for name in ("migrate", "api", "worker"):
        command = services[name]["command"]
        assert command[0] == "rigforge"
        result = runner.invoke(app, [command[1], "--help"])
        assert result.exit_code == 0, (name, result.output)
        for flag in (c for c in command[2:] if c.startswith("--")):
            assert flag in result.output, (name, flag)
    env = services["api"]["environment"]
    assert env["RIGFORGE_BROKER_URL"].startswith("redis://") and env["RIGFORGE_DATABASE_URL"].startswith("postgresql+psycopg://")
