"""`rigforge submit` and `rigforge jobs ...` against a real `rigforge serve`, with no --url or --key: the local
install's URL and `.rigforge/local-api-key` are found by themselves. Output is read as in CI logs (not a TTY)."""

from __future__ import annotations

import hashlib
import json
import re
from urllib.parse import urlparse

import pytest
import trimesh
from typer.testing import CliRunner

from api.settings import get_settings
from cli.main import app
from tests.meshes import glb_bytes


@pytest.fixture
def local_install(dashboard_server, monkeypatch):
    """The environment of a shell on the server's machine: its data dir and port, no URL or key given."""
    monkeypatch.setenv("RIGFORGE_DATA_DIR", str(dashboard_server.data_dir))
    monkeypatch.setenv("RIGFORGE_PORT", str(urlparse(dashboard_server.url).port))
    for name in ("RIGFORGE_URL", "RIGFORGE_API_KEY", "RIGFORGE_KEY", "RIGFORGE_HOST"):
        monkeypatch.delenv(name, raising=False)
    get_settings.cache_clear()
    yield dashboard_server
    get_settings.cache_clear()


def rigforge(*args: str) -> tuple[int, str, str]:
    result = CliRunner().invoke(app, list(args))
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result.exit_code, result.stdout, result.stderr


def test_submit_then_list_get_download_logs_cancel_and_delete_with_local_defaults(local_install, tmp_path):
    mesh = tmp_path / "box.glb"
    mesh.write_bytes(glb_bytes(trimesh.creation.box(extents=(0.3, 1.0, 0.2))))

    code, out, err = rigforge("submit", str(mesh), "--options", '{"stages": []}', "--wait")
    assert code == 0, err
    job_id, *progress = out.splitlines()
    assert progress and all(line.startswith(f"job {job_id[:8]} ") for line in progress)
    stages = [line.split()[2] for line in progress]
    assert len(stages) == len(set(stages))  # one line per stage change, not per progress update

    code, out, _ = rigforge("jobs", "list", "--json")
    assert code == 0 and job_id in [j["id"] for j in json.loads(out)["items"]]
    code, out, _ = rigforge("jobs", "list")
    assert code == 0 and re.search(rf"{job_id}\s+succeeded\s+\S+\s+box.glb", out), out

    code, out, _ = rigforge("jobs", "get", job_id)
    assert code == 0 and "status     succeeded" in out and "artifact   report.json" in out, out
    job = json.loads(rigforge("jobs", "get", job_id, "--json")[1])

    code, out, _ = rigforge("jobs", "download", job_id, "-o", str(tmp_path / "out"), "--name", "report.json", "--json")
    assert code == 0, out
    [saved] = json.loads(out)
    record = next(a for a in job["artifacts"] if a["name"] == "report.json")
    assert hashlib.sha256((tmp_path / "out" / "report.json").read_bytes()).hexdigest() == saved["sha256"] == record["sha256"]
    code, _, err = rigforge("jobs", "download", job_id, "--name", "rigged.fbx")
    assert code == 1 and "has no artifact rigged.fbx; it has: " in err

    code, out, _ = rigforge("jobs", "logs", job_id)
    assert code == 0 and "submitted box.glb" in out.splitlines()[0] and out.splitlines()[-1].endswith("succeeded"), out

    code, _, err = rigforge("jobs", "cancel", job_id)
    assert code == 1 and err.startswith("error: HTTP 409 [job_finished]") and "Traceback" not in err

    code, out, _ = rigforge("jobs", "delete", job_id)
    assert code == 0 and out.strip() == f"{job_id} deleted"
    code, _, err = rigforge("jobs", "get", job_id)
    assert code == 1 and err.startswith("error: HTTP 404 [job_not_found]")
