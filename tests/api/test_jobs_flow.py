"""Submitting, reading, listing, cancelling and downloading jobs through the HTTP API."""

from __future__ import annotations

import json

import numpy as np
import pytest

from simcore.io.gltf_document import GltfDocument
from tests.api.conftest import BACKENDS, INGEST_ONLY

pytestmark = pytest.mark.parametrize("storage_backend", BACKENDS, indirect=True)  # the same tests on S3


def submit(client, auth, data: bytes, name="fox.glb", options=INGEST_ONLY, headers=None, **files):
    return client.post("/api/v1/jobs", headers={**auth, **(headers or {})},
                       files={"mesh": (name, data), **files}, data={"options": options} if options is not None else None)


def test_fox_ingest_job_succeeds_with_mesh_and_report(client, auth, dev_assets):
    fox = (dev_assets / "fox.glb").read_bytes()
    r = submit(client, auth, fox)
    assert r.status_code == 202, r.text
    job = client.get(f"/api/v1/jobs/{r.json()['id']}", headers=auth).json()
    assert job["status"] == "succeeded", job
    assert job["progress"] == 1.0 and job["error"] is None and job["mesh"]["format"] == "glb"
    names = {a["name"]: a for a in job["artifacts"]}
    assert {"mesh.glb", "report.json"} <= set(names)
    mesh = client.get(names["mesh.glb"]["url"], headers=auth)
    assert mesh.headers["content-type"] == "model/gltf-binary"
    doc = GltfDocument.from_bytes(mesh.content)
    assert sum(doc.items("accessors")[p["attributes"]["POSITION"]]["count"] for m in doc.items("meshes") for p in m["primitives"]) == 1728
    report = client.get(names["report.json"]["url"], headers=auth).json()
    assert report["mesh"]["vertices"] == 1728 and report["mesh"]["units_applied"] == "cm"
    assert 0.7 < report["mesh"]["size"][1] < 0.9  # the fox stands about 0.79 m tall once in metres


def test_idempotency_key_returns_the_same_job_and_refuses_a_different_body(client, auth, dev_assets):
    fox = (dev_assets / "fox.glb").read_bytes()
    first = submit(client, auth, fox, headers={"Idempotency-Key": "build-42"})
    again = submit(client, auth, fox, headers={"Idempotency-Key": "build-42"})
    assert first.status_code == again.status_code == 202
    assert first.json()["id"] == again.json()["id"]
    other = submit(client, auth, fox, options='{"stages": [], "max_joints": 10}', headers={"Idempotency-Key": "build-42"})
    assert other.status_code == 409 and other.json()["code"] == "idempotency_conflict"


def test_another_keys_job_answers_404(client, auth, other_auth, dev_assets):
    job_id = submit(client, auth, (dev_assets / "fox.glb").read_bytes()).json()["id"]
    for path in (f"/api/v1/jobs/{job_id}", f"/api/v1/jobs/{job_id}/artifacts/mesh.glb", f"/api/v1/jobs/{job_id}/events"):
        r = client.get(path, headers=other_auth)
        assert r.status_code == 404 and r.headers["content-type"] == "application/problem+json", path
    assert client.get("/api/v1/jobs", headers=other_auth).json()["items"] == []


def test_missing_or_wrong_key_is_401_problem(client):
    r = client.get("/api/v1/jobs")
    assert r.status_code == 401 and r.json()["code"] == "unauthorized"
    r = client.get("/api/v1/jobs", headers={"Authorization": "Bearer rf_nope"})
    assert r.status_code == 401


def test_list_is_newest_first_with_cursor_pages_and_status_filter(client, auth, dev_assets):
    fox = (dev_assets / "fox.glb").read_bytes()
    ids = [submit(client, auth, fox, options=json.dumps({"stages": [], "max_joints": 10 + i})).json()["id"] for i in range(3)]
    page1 = client.get("/api/v1/jobs?limit=2", headers=auth).json()
    page2 = client.get(f"/api/v1/jobs?limit=2&cursor={page1['next_cursor']}", headers=auth).json()
    assert [j["id"] for j in page1["items"] + page2["items"]] == ids[::-1]
    assert page2["next_cursor"] is None
    assert len(client.get("/api/v1/jobs?status=succeeded", headers=auth).json()["items"]) == 3
    assert client.get("/api/v1/jobs?status=failed", headers=auth).json()["items"] == []
    assert client.get("/api/v1/jobs?cursor=garbage", headers=auth).status_code == 422


def test_cancel_a_queued_job_and_refuse_cancelling_a_finished_one(client, auth, inline_worker, monkeypatch, dev_assets):
    fox = (dev_assets / "fox.glb").read_bytes()
    done = submit(client, auth, fox).json()
    r = client.post(f"/api/v1/jobs/{done['id']}/cancel", headers=auth)
    assert r.status_code == 409 and r.json()["code"] == "job_finished"
    monkeypatch.setattr("worker.celery_app.enqueue", lambda job_id: None)  # nobody picks it up
    queued = submit(client, auth, fox, options='{"stages": [], "max_joints": 11}').json()
    assert queued["status"] == "queued"
    r = client.post(f"/api/v1/jobs/{queued['id']}/cancel", headers=auth)
    assert r.status_code == 202 and r.json()["status"] == "canceled"


def test_events_stream_ends_with_the_final_state(client, auth, dev_assets):
    job_id = submit(client, auth, (dev_assets / "fox.glb").read_bytes()).json()["id"]
    with client.stream("GET", f"/api/v1/jobs/{job_id}/events", headers=auth) as r:
        assert r.headers["content-type"].startswith("text/event-stream")
        events = [json.loads(line[6:]) for line in r.iter_lines() if line.startswith("data: ")]
    assert events[-1]["status"] == "succeeded" and events[-1]["progress"] == 1.0


def test_health_and_readiness(client):
    assert client.get("/healthz").json() == {"status": "ok"}
    ready = client.get("/readyz")
    assert ready.status_code == 200 and ready.json()["checks"] == {"database": "ok", "broker": "ok", "storage": "ok"}


def test_openapi_is_served_with_clean_operation_ids(client):
    spec = client.get("/openapi.json").json()
    ops = {op["operationId"] for path in spec["paths"].values() for op in path.values()}
    assert {"submitJob", "getJob", "listJobs", "cancelJob", "streamJobEvents"} <= ops


def test_uploaded_bvh_clip_is_named_after_the_uploaded_file(client, auth, dev_assets):
    from tests.simcore.motion.motion_samples import bvh_text, humanoid

    skel = humanoid(prefix="")
    angles = np.zeros((12, skel.num_joints, 3))
    angles[:, skel.names.index("LeftUpLeg"), 1] = 20 * np.sin(np.arange(12) / 3)
    roots = np.stack([np.zeros(12), np.full(12, 1.0), np.arange(12) * 0.03], axis=1)
    bvh = bvh_text(skel, roots, angles, ["ZXY"] * skel.num_joints).encode()
    r = client.post("/api/v1/jobs", headers=auth,
                    files={"mesh": ("rigged_figure.glb", (dev_assets / "rigged_figure.glb").read_bytes()), "motion": ("studio walk.bvh", bvh)},
                    # warn: this toy's shoulders come near the gate's floor under the synthetic clip's T-pose (0.41× at
                    # the 1st percentile against 0.398); the test is about the clip's name, not its quality
                    data={"options": '{"skeleton": "keep", "stages": ["skeleton", "skin", "motion"], "quality_gate": "warn"}'})
    assert r.status_code == 202, r.text
    job = client.get(f"/api/v1/jobs/{r.json()['id']}", headers=auth).json()
    assert job["status"] == "succeeded", job
    report_url = next(a["url"] for a in job["artifacts"] if a["name"] == "report.json")
    clip = client.get(report_url, headers=auth).json()["motion"]["clip"]
    assert clip["name"] == "studio walk" and clip["source_format"] == "bvh"  # not the stored file's hash name
