"""`rigforge submit` with several meshes: a concurrency limit, one line per job off a terminal, downloads per file."""

from __future__ import annotations

import hashlib
import json
import threading
import time

import httpx
import pytest
from typer.testing import CliRunner

from cli import submit as submit_cli
from cli.main import app


class FakeService:
    """The jobs API in memory: a job fails when its file is named bad*, the events stream ends the job."""

    def __init__(self):
        self.jobs: dict[str, dict] = {}
        self.keys: dict[str, str] = {}
        self.in_flight = self.most_in_flight = 0
        self.lock = threading.Lock()

    def handle(self, request: httpx.Request) -> httpx.Response:
        path = request.url.path
        if request.method == "POST" and path == "/api/v1/jobs":
            key = request.headers["Idempotency-Key"]
            name = request.content.split(b'filename="', 1)[1].split(b'"', 1)[0].decode()
            job_id = self.keys.setdefault(key, f"job-{len(self.keys)}")
            self.jobs[job_id] = {"id": job_id, "status": "queued", "progress": 0.0, "stage": None, "name": name}
            return httpx.Response(202, json=self.jobs[job_id])
        job = self.jobs[path.split("/")[4]]
        if path.endswith("/events"):
            with self.lock:
                self.in_flight += 1
                self.most_in_flight = max(self.most_in_flight, self.in_flight)
            time.sleep(0.05)
            with self.lock:
                self.in_flight -= 1
            bad = job["name"].startswith("bad")
            final = {**job, "status": "failed" if bad else "succeeded", "progress": 1.0,
                     "error": {"code": "unknown_format", "message": "not a mesh"} if bad else None,
                     "artifacts": [] if bad else [{"name": "report.json", "size": 2, "sha256": hashlib.sha256(b"{}").hexdigest()}]}
            return httpx.Response(200, text=f"data: {json.dumps(final)}\n\n")
        return httpx.Response(200, content=b"{}")


@pytest.fixture
def service(monkeypatch):
    fake = FakeService()
    real = httpx.Client

    def client(*args, **kwargs):
        return real(*args, transport=httpx.MockTransport(fake.handle), **kwargs)

    monkeypatch.setattr(submit_cli.httpx, "Client", client)
    return fake


def _folder(tmp_path, names):
    folder = tmp_path / "meshes"
    folder.mkdir()
    for name in names:
        (folder / name).write_bytes(b"glTF")
    (folder / "notes.txt").write_text("not a mesh")
    return folder


def test_a_folder_runs_with_bounded_concurrency_and_one_line_per_job(service, tmp_path):
    folder = _folder(tmp_path, [f"m{k}.glb" for k in range(6)])
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["submit", str(folder), "--url", "http://svc", "--key", "k", "--concurrency", "2",
                                      "-o", str(out)])
    assert result.exit_code == 0, result.output
    lines = [line for line in result.output.splitlines() if line.startswith("jobs ")]
    assert len(lines) == 6 and all(line.endswith("\tsucceeded") for line in lines)
    assert 2 == service.most_in_flight
    assert sorted(p.name for p in out.iterdir()) == [f"m{k}" for k in range(6)]
    assert (out / "m3" / "report.json").read_bytes() == b"{}"


def test_a_failed_job_fails_the_batch_and_says_why(service, tmp_path):
    folder = _folder(tmp_path, ["good.glb", "bad.glb"])
    result = CliRunner().invoke(app, ["submit", str(folder / "good.glb"), str(folder / "bad.glb"), "--url", "http://svc",
                                      "--key", "k", "--wait"])
    assert result.exit_code == 1
    assert "bad.glb\tjob-" in result.output and "\tfailed\t[unknown_format] not a mesh" in result.output
    assert "1 of 2 jobs did not succeed" in result.output


def test_a_retried_batch_reuses_its_jobs(service, tmp_path):
    folder = _folder(tmp_path, ["a.glb", "b.glb"])
    meshes = submit_cli.mesh_files([folder])
    make = lambda key: httpx.Client(base_url="http://svc", headers={"Idempotency-Key": key})  # noqa: E731
    first = submit_cli.run_batch(make, meshes, idempotency_key="ci-42")
    again = submit_cli.run_batch(make, meshes, idempotency_key="ci-42")
    assert [r.job_id for r in first] == [r.job_id for r in again] and len({r.job_id for r in first}) == 2


def test_one_file_keeps_the_single_job_output(service, tmp_path):
    folder = _folder(tmp_path, ["fox.glb"])
    result = CliRunner().invoke(app, ["submit", str(folder / "fox.glb"), "--url", "http://svc", "--key", "k",
                                      "-o", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    assert result.output.splitlines()[0] == "job-0"
    assert f"{tmp_path / 'out' / 'report.json'}  (2 bytes)" in result.output


def test_an_edited_skeleton_goes_with_its_source_job(service, tmp_path, monkeypatch):
    seen = {}
    handle = service.handle

    def spy(request: httpx.Request) -> httpx.Response:
        if request.method == "POST":
            seen["body"] = request.content
        return handle(request)

    monkeypatch.setattr(service, "handle", spy)
    folder = _folder(tmp_path, ["fox.glb"])
    (folder / "edited.json").write_text('{"names": ["root"]}')
    result = CliRunner().invoke(app, ["submit", str(folder / "fox.glb"), "--url", "http://svc", "--key", "k",
                                      "--skeleton", str(folder / "edited.json"), "--source-job", "job-7"])
    assert result.exit_code == 0, result.output
    assert b'name="skeleton"; filename="edited.json"' in seen["body"] and b"job-7" in seen["body"]
