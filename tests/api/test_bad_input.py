"""Bad uploads get a clear 4xx problem (or a failed job with a clear code); nothing escapes the data dir."""

from __future__ import annotations

import base64
import json
import os
import tempfile

import numpy as np
import pytest

from tests.api.conftest import INGEST_ONLY
from tests.hostile.gltf_cases import glb


def triangle_gltf(positions: np.ndarray, buffer_length: int | None = None, uri: str | None = None) -> dict:
    data = positions.astype(np.float32).tobytes()
    buffer: dict[str, int | str] = {"byteLength": buffer_length or len(data)}
    if uri:
        buffer["uri"] = uri
    return {"asset": {"version": "2.0"}, "buffers": [buffer],
            "bufferViews": [{"buffer": 0, "byteLength": len(data)}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                           "min": [0, 0, 0], "max": [1, 1, 0]}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}], "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}]}


TRI = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)


def post(client, auth, mesh: bytes | None, name="upload.bin", options=INGEST_ONLY):
    files = {"mesh": (name, mesh)} if mesh is not None else {"motion": ("x.bvh", b"HIERARCHY")}
    return client.post("/api/v1/jobs", headers=auth, files=files, data={"options": options} if options is not None else None)


def assert_problem(r, status: int, code: str, field: str | None = None) -> None:
    assert r.status_code == status, r.text
    assert r.headers["content-type"] == "application/problem+json"
    body = r.json()
    assert {"type", "title", "status", "detail", "code"} <= set(body) and body["code"] == code, body
    if field:
        assert body["field"] == field, body


def test_valid_triangle_glb_is_accepted(client, auth):
    r = post(client, auth, glb(triangle_gltf(TRI), TRI.tobytes()), "tri.glb")
    assert r.status_code == 202 and r.json()["status"] == "succeeded", r.text


@pytest.mark.parametrize(
    ("make", "status", "code"),
    [
        (lambda: b"", 422, "empty_file"),
        (lambda: glb(triangle_gltf(TRI), TRI.tobytes())[:-20], 422, "invalid_gltf"),  # truncated
        (lambda: glb(triangle_gltf(TRI, buffer_length=10_000), TRI.tobytes()), 422, "invalid_gltf"),  # buffer length lies
        (lambda: json.dumps(triangle_gltf(TRI, uri="../../etc/passwd")).encode(), 422, "external_uri"),
        (lambda: np.random.default_rng(0).bytes(10 * 1024 * 1024 // 8), 422, "unknown_format"),
        (lambda: b"Kaydara FBX Binary  \x00\x1a\x00" + bytes(100), 415, "unsupported_format"),
        (lambda: b"HIERARCHY\nROOT Hips\n{\n}\n", 422, "wrong_kind"),  # a BVH where a mesh belongs
    ],
    ids=["empty", "truncated-glb", "lying-buffer-length", "path-escape-uri", "random-bytes", "fbx", "bvh-as-mesh"],
)
def test_bad_mesh_uploads_get_a_4xx_problem_naming_the_field(client, auth, make, status, code):
    assert_problem(post(client, auth, make()), status, code, "mesh")


def test_nan_vertices_fail_the_job_with_a_clear_code(client, auth):
    nan = TRI.copy()
    nan[1, 0] = np.nan
    r = post(client, auth, glb(triangle_gltf(nan), nan.tobytes()), "nan.glb")
    assert r.status_code == 202
    job = r.json()
    assert job["status"] == "failed" and job["error"]["code"] == "non_finite", job


def test_obj_with_out_of_range_index_fails_clearly(client, auth):
    r = post(client, auth, b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", "bad.obj")
    job = r.json()
    assert r.status_code == 202 and job["status"] == "failed", job
    assert job["error"]["code"] in ("index_out_of_range", "unreadable_mesh", "empty_mesh")


def test_over_cap_upload_is_413(client, auth):
    r = post(client, auth, b"v 0 0 0\n" * (600 * 1024), "big.obj")  # 4.8 MB against a 2 MB cap
    assert_problem(r, 413, "upload_too_large")


def test_missing_mesh_field_names_the_field(client, auth):
    assert_problem(post(client, auth, None), 422, "validation_error", "mesh")


@pytest.mark.parametrize(("options", "field"), [("{not json", "options"), ('{"skinning": "magic"}', "options.skinning"),
                                                ('{"unknown_knob": 1}', "options.unknown_knob"), ("[1, 2]", "options"),
                                                ('{"exclude_joints": "*IK*"}', "options.exclude_joints"),
                                                ('{"exclude_joints": [""]}', "options.exclude_joints.0")])
def test_invalid_options_name_the_option(client, auth, options, field):
    assert_problem(post(client, auth, b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "t.obj", options=options), 422, "invalid_options", field)


def test_uploads_and_spooling_stay_inside_the_data_dir(client, auth, data_dir):
    assert os.path.commonpath([tempfile.gettempdir(), str(data_dir)]) == str(data_dir)
    post(client, auth, base64.b64encode(os.urandom(300_000)), "noise.bin")
    stored = [p for p in data_dir.rglob("*") if p.is_file()]
    assert stored and all(p.resolve().is_relative_to(data_dir.resolve()) for p in stored)
