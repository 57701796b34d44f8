"""An example job as the API answers it, shown in the OpenAPI document (tests check it fits JobOut)."""

from __future__ import annotations

from typing import Any

_ID = "8f2d4c1e-5b7a-4e39-9c0d-2a6b1f3e7d90"
_URL = f"https://rigforge.example/api/v1/jobs/{_ID}/artifacts"
_SIGNED = f"https://rigforge.example/api/v1/files/{_ID}"
_LINK = "expires=1795709765&sig=5c1e0f2b9a7d4e8c3f6a1b0d2e9c8f7a6b5d4c3e2f1a0b9c8d7e6f5a4b3c2d1e"

JOB_EXAMPLE: dict[str, Any] = {
    "id": _ID,
    "status": "succeeded",
    "stage": "export",
    "progress": 1.0,
    "created_at": "2026-11-25T16:15:48.398753Z",
    "started_at": "2026-11-25T16:15:49.481670Z",
    "finished_at": "2026-11-25T16:16:05.614384Z",
    "options": {"skeleton": "auto", "skinning": "auto", "max_joints": 64, "motion": {"in_place": True}},
    "attempts": 1,
    "mesh": {"filename": "fox.glb", "format": "glb", "size": 163976, "sha256": "3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855f"},
    "motion": {"filename": "walk.bvh", "format": "bvh", "size": 48211, "sha256": "e3b98a4da31a127d4bde6e43033f66ba274cab0eb7eb1c70ec41402bf6273dd8"},
    "skeleton": None,
    "source_job_id": None,
    "error": None,
    "warnings": [{"code": "ground_plane_removed", "stage": "skeleton", "message": "a flat part under the model was left out of the skeleton",
                  "figure": None, "threshold": None, "hard": False, "frame": None}],
    "artifacts": [
        {"name": "rigged.glb", "media_type": "model/gltf-binary", "size": 171032,
         "sha256": "9f86d081884c7d659a2feaa0c55ad015a3bf4f1b2b0b822cd15d6c15b0f00a08", "url": f"{_URL}/rigged.glb",
         "download_url": f"{_SIGNED}/rigged.glb?{_LINK}"},
        {"name": "report.json", "media_type": "application/json", "size": 5210,
         "sha256": "60303ae22b998861bce3b28f33eec1be758a213c86c93c076dbe9f558c11c752", "url": f"{_URL}/report.json",
         "download_url": f"{_SIGNED}/report.json?{_LINK}"},
    ],
    "callback_url": None,
    "webhooks": [],
    "download_all_url": None,
}
