"""A client generated from /openapi.json by openapi-python-client drives one job: submit, poll, download."""

from __future__ import annotations

import hashlib
import importlib
import io
import subprocess
import sys
import time
from pathlib import Path

import trimesh

from tests.meshes import glb_bytes

GENERATOR = Path(sys.executable).with_name("openapi-python-client")
# The zip download is application/zip, which the generator reads only as octet-stream.
CONFIG = """package_name_override: rigforge_client
post_hooks: []
content_type_overrides:
  application/zip: application/octet-stream
"""


def generate_client(spec: bytes, where: Path) -> None:
    """Write the `rigforge_client` package into `where`."""
    (where / "openapi.json").write_bytes(spec)
    (where / "config.yaml").write_text(CONFIG)
    run = subprocess.run([str(GENERATOR), "generate", "--path", "openapi.json", "--config", "config.yaml", "--meta", "none",
                          "--output-path", "rigforge_client", "--fail-on-warning"], cwd=where, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr


def test_a_generated_client_submits_polls_and_downloads_a_job(client, auth, tmp_path, monkeypatch):
    generate_client(client.get("/openapi.json").content, tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    for name in [m for m in sys.modules if m.split(".")[0] == "rigforge_client"]:
        monkeypatch.delitem(sys.modules, name)
    rc = importlib.import_module("rigforge_client")
    jobs = importlib.import_module("rigforge_client.api.jobs")
    models = importlib.import_module("rigforge_client.models")
    types = importlib.import_module("rigforge_client.types")
    for op in ("submit_job", "get_job", "download_artifact"):
        importlib.import_module(f"rigforge_client.api.jobs.{op}")

    # The generated client builds every request (bearer header included); TestClient's transport runs the app in-process.
    api = rc.AuthenticatedClient(base_url=str(client.base_url), token=auth["Authorization"].split()[1],
                                 httpx_args={"transport": client._transport})
    mesh = glb_bytes(trimesh.creation.box(extents=(0.3, 1.0, 0.2)))
    form = models.BodySubmitJob(mesh=types.File(payload=io.BytesIO(mesh), file_name="box.glb", mime_type="model/gltf-binary"),
                                options=models.JobOptions.from_dict({"stages": [], "max_joints": 12}))

    submitted = jobs.submit_job.sync(client=api, body=form)
    assert isinstance(submitted, models.JobOut), submitted
    assert submitted.options.additional_properties["max_joints"] == 12  # the options part arrived as JSON

    deadline = time.monotonic() + 30
    job = jobs.get_job.sync(job_id=submitted.id, client=api)
    while job.status.value in ("queued", "running") and time.monotonic() < deadline:
        time.sleep(0.2)
        job = jobs.get_job.sync(job_id=submitted.id, client=api)
    assert job.status.value == "succeeded", job.error

    report = next(a for a in job.artifacts if a.name == "report.json")
    downloaded = jobs.download_artifact.sync(job_id=job.id, name=report.name, client=api)
    assert isinstance(downloaded, types.File)
    assert hashlib.sha256(downloaded.payload.read()).hexdigest() == report.sha256

    missing = jobs.get_job.sync(job_id="00000000-0000-0000-0000-000000000000", client=api)
    assert isinstance(missing, models.ProblemDetails) and missing.code == "job_not_found"
