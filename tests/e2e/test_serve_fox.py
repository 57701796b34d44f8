"""The README's run path: `rigforge serve` on the embedded default, fox.glb over HTTP, SSE to the end."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import httpx
import pytest

from simcore.io.gltf_document import GltfDocument
from tests.integration.conftest import REPO, free_port, wait_for

pytestmark = pytest.mark.integration


@pytest.fixture
def server(tmp_path):
    port = free_port()
    env = {**os.environ, "RIGFORGE_DATA_DIR": str(tmp_path / "data")}
    started = time.monotonic()
    proc = subprocess.Popen([sys.executable, "-m", "cli.main", "serve", "--port", str(port)], cwd=tmp_path, env=env,
                            start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    url = f"http://127.0.0.1:{port}"

    def healthy() -> bool:
        try:
            return httpx.get(f"{url}/healthz", timeout=1).status_code == 200
        except httpx.HTTPError:
            return False

    try:
        wait_for(healthy, 60, 0.1)
        print(f"time to first healthy response: {time.monotonic() - started:.2f} s")
        key = (tmp_path / "data" / "local-api-key").read_text().strip()
        yield url, key, env, tmp_path
    finally:
        proc.send_signal(signal.SIGINT)  # what Ctrl-C sends: API and embedded worker stop cleanly
        out, _ = proc.communicate(timeout=60)
        assert proc.returncode == 0, out[-3000:]


def test_fox_through_the_running_service(server, dev_assets):
    url, key, _, _ = server
    headers = {"Authorization": f"Bearer {key}"}
    started = time.monotonic()
    with httpx.Client(base_url=url, headers=headers, timeout=60) as client:
        r = client.post("/api/v1/jobs", files={"mesh": ("fox.glb", (dev_assets / "fox.glb").read_bytes())})
        assert r.status_code == 202, r.text
        job_id = r.json()["id"]
        with client.stream("GET", f"/api/v1/jobs/{job_id}/events", timeout=600) as stream:
            events = [json.loads(line[6:]) for line in stream.iter_lines() if line.startswith("data: ")]
        print(f"fox job: {time.monotonic() - started:.2f} s, {len(events)} events, stages {[e['stage'] for e in events]}")
        assert events[-1]["status"] == "succeeded", events[-1]
        progress = [e["progress"] for e in events]
        assert progress == sorted(progress) and progress[-1] == 1.0
        mesh = client.get(f"/api/v1/jobs/{job_id}/artifacts/mesh.glb")
        assert mesh.status_code == 200 and mesh.headers["content-type"] == "model/gltf-binary"
        assert GltfDocument.from_bytes(mesh.content).items("meshes")


def test_cli_submit_waits_and_downloads(server, dev_assets, tmp_path):
    url, key, env, _ = server
    out = tmp_path / "out"
    run = subprocess.run([sys.executable, "-m", "cli.main", "submit", str(dev_assets / "fox.glb"), "--url", url, "--key", key,
                          "--options", '{"stages": []}', "--wait", "-o", str(out)], cwd=REPO, env=env, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert (out / "mesh.glb").stat().st_size > 0 and json.loads((out / "report.json").read_text())["mesh"]["vertices"] == 1728
    bad = tmp_path / "noise.glb"
    bad.write_bytes(os.urandom(5000))
    run = subprocess.run([sys.executable, "-m", "cli.main", "submit", str(bad), "--url", url, "--key", key, "--wait"],
                         cwd=REPO, env=env, capture_output=True, text=True, timeout=120)
    assert run.returncode == 1 and "unknown_format" in run.stderr
