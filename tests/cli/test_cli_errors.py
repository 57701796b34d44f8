"""The CLI answers a missing database, a missing key or an unreachable service with one clear line, no traceback."""

from __future__ import annotations

import hashlib
import sqlite3

import httpx
import pytest
from typer.testing import CliRunner

from api.db import reset_caches
from api.settings import get_settings
from cli import service_client
from cli.main import app
from cli.progress import stage_bar
from tests.integration.conftest import free_port


@pytest.fixture
def elsewhere(tmp_path, monkeypatch):
    """A shell outside any RigForge checkout: no data directory, no URL or key in the environment."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("RIGFORGE_DATA_DIR", str(tmp_path / ".rigforge"))
    for name in ("RIGFORGE_URL", "RIGFORGE_API_KEY", "RIGFORGE_KEY", "RIGFORGE_DATABASE_URL"):
        monkeypatch.delenv(name, raising=False)
    get_settings.cache_clear()
    yield tmp_path
    get_settings.cache_clear()
    reset_caches()  # forget the engine a keys command opened here


def rigforge(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(app, list(args))
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result.exit_code, result.stderr


def test_keys_outside_the_service_say_where_to_run_and_create_nothing(elsewhere):
    code, err = rigforge("keys", "list")
    assert code == 1 and err.startswith("error: no RigForge database at ") and "RIGFORGE_DATABASE_URL" in err
    assert "Traceback" not in err and not (elsewhere / ".rigforge").exists()


def test_keys_on_an_unmigrated_database_say_to_migrate(elsewhere):
    (elsewhere / ".rigforge").mkdir()
    sqlite3.connect(elsewhere / ".rigforge" / "rigforge.db").close()
    code, err = rigforge("keys", "create", "--name", "ci")
    assert code == 1 and "no such table: api_keys" in err and "`rigforge migrate`" in err


def test_jobs_without_a_key_say_how_to_give_one(elsewhere):
    code, err = rigforge("jobs", "list")
    assert code == 1 and err.startswith("error: no API key: pass --key, set RIGFORGE_API_KEY")


def test_an_unreachable_service_exits_2_naming_it(elsewhere):
    url = f"http://127.0.0.1:{free_port()}"
    code, err = rigforge("jobs", "get", "some-job", "--url", url, "--key", "rf_x")
    assert code == 2 and err.startswith(f"error: cannot reach {url}")


def test_progress_off_a_terminal_is_one_line_per_stage_change(capsys):
    with stage_bar("job 1234") as update:
        for stage, fraction in [("queued", 0.0), ("ingest", 0.1), ("ingest", 0.2), ("skeleton", 0.4), ("skeleton", 0.5)]:
            update(stage, fraction)
    assert capsys.readouterr().out.splitlines() == ["job 1234 queued 0%", "job 1234 ingest 10%", "job 1234 skeleton 40%"]


def test_a_download_that_does_not_match_the_jobs_sha256_fails(elsewhere, monkeypatch):
    job = {"id": "j1", "status": "succeeded", "artifacts": [{"name": "report.json", "size": 2, "sha256": hashlib.sha256(b"{}").hexdigest()}]}

    def handle(request: httpx.Request) -> httpx.Response:
        return httpx.Response(200, json=job) if request.url.path == "/api/v1/jobs/j1" else httpx.Response(200, content=b"{!")

    real = httpx.Client
    monkeypatch.setattr(service_client.httpx, "Client", lambda *a, **kw: real(*a, transport=httpx.MockTransport(handle), **kw))
    code, err = rigforge("jobs", "download", "j1", "--url", "http://rigforge.test", "--key", "rf_x", "-o", str(elsewhere / "out"))
    assert code == 1 and "report.json: sha256 differs from the job's record" in err


@pytest.mark.parametrize("command", [["rig", "mesh.obj"], ["eval", "motion", "."]])
def test_invalid_options_exit_2_naming_the_field(elsewhere, command):
    (elsewhere / "mesh.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    code, err = rigforge(*command, "--options", '{"skinning": "magic"}')
    assert code == 2 and err.startswith("invalid --options:") and "skinning" in err
    code, err = rigforge(*command, "--options", "{not json")
    assert code == 2 and err.startswith("invalid --options:")


def test_an_input_error_no_command_catches_is_one_line_with_its_field(tmp_path):
    """The console entry point turns a SimcoreError into `error [code] (field): message`, exit 2, no traceback."""
    import subprocess
    import sys

    (tmp_path / "MANIFEST.tsv").write_text("name\tsplit\n")
    done = subprocess.run([sys.executable, "-m", "cli.main", "eval", "skin", str(tmp_path), "--method", "nonsense"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2, done.stderr
    assert done.stderr.startswith("error [invalid_option] (method): unknown skinning method 'nonsense'")
    assert "Traceback" not in done.stderr
