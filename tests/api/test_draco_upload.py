"""A Draco upload is checked by the API without decoding it: decoding is the worker's job."""

from __future__ import annotations

import trimesh

from tests.simcore.io.rig_export_fixtures import draco_gltf


def test_the_api_checks_a_draco_upload_without_decoding_it(client, auth, monkeypatch) -> None:
    import simcore.io.gltf_document as gltf_document

    def no_decoding(doc):
        raise AssertionError("the API process decoded Draco data")

    monkeypatch.setattr(gltf_document, "decompress_draco", no_decoding)
    monkeypatch.setattr("worker.celery_app.enqueue", lambda job_id: None)  # leave the job queued
    capsule = trimesh.creation.capsule(height=0.8, radius=0.15, count=[12, 12])
    files = {"mesh": ("capsule.gltf", draco_gltf(capsule), "model/gltf+json")}
    r = client.post("/api/v1/jobs", files=files, headers=auth)
    assert r.status_code == 202 and r.json()["status"] == "queued", r.text
