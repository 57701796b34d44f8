"""The API process stays light (no torch/warp) and refuses oversized bodies before reading them."""

from __future__ import annotations

import subprocess
import sys

from tests.integration.conftest import REPO


def test_api_app_does_not_import_heavy_compute_libraries(tmp_path):
    code = "import sys, api.app; api.app.create_app(); print(sorted(m for m in ('torch', 'warp', 'pxr', 'trimesh') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, check=True,
                         env={"RIGFORGE_DATA_DIR": str(tmp_path), "PATH": ""})
    assert out.stdout.strip() == "[]", out.stdout


def test_declared_oversized_body_is_refused_up_front(client, auth):
    r = client.post("/api/v1/jobs", headers={**auth, "Content-Length": str(50 * 1024 * 1024), "Content-Type": "multipart/form-data; boundary=x"},
                    content=b"--x--\r\n")
    assert r.status_code == 413 and r.json()["code"] == "upload_too_large"


def test_large_json_responses_are_gzipped_when_asked(client, auth):
    r = client.get("/openapi.json", headers={"Accept-Encoding": "gzip"})
    assert r.status_code == 200 and r.headers.get("content-encoding") == "gzip"
