"""Draco-compressed glTF uploads decode to the same mesh; meshopt-compressed ones are refused by name."""

from __future__ import annotations

import base64
import json
from pathlib import Path

import DracoPy
import numpy as np
import pytest
import trimesh

from simcore.errors import InvalidInput, UnsupportedFormat
from simcore.ingest import ingest
from simcore.io.gltf_document import GltfDocument
from simcore.options import JobOptions
from simcore.pipeline import PipelineInputs, run_pipeline

CAPSULE = trimesh.creation.capsule(height=0.8, radius=0.15, count=[12, 12])


def _draco_gltf(mesh: trimesh.Trimesh, *, payload: bytes | None = None, required: str = "KHR_draco_mesh_compression") -> bytes:
    """A .gltf whose one primitive is Draco-compressed (POSITION, NORMAL, indices); accessors have no bufferView."""
    pos = mesh.vertices.astype(np.float32)
    blob = payload if payload is not None else DracoPy.encode(pos, mesh.faces.astype(np.uint32), preserve_order=True,
                                                              normals=mesh.vertex_normals)
    decoded = DracoPy.decode(blob) if payload is None else None
    uids = {a["attribute_type"]: a["unique_id"] for a in decoded.attributes} if decoded else {0: 0, 1: 1}
    draco = {"bufferView": 0, "attributes": {"POSITION": uids[0], "NORMAL": uids[1]}}
    doc = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "extensionsUsed": [required], "extensionsRequired": [required],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2,
                                    "extensions": {"KHR_draco_mesh_compression": draco}}]}],
        "accessors": [
            {"componentType": 5126, "count": len(pos), "type": "VEC3", "min": pos.min(0).tolist(), "max": pos.max(0).tolist()},
            {"componentType": 5126, "count": len(pos), "type": "VEC3"},
            {"componentType": 5123, "count": 3 * len(mesh.faces), "type": "SCALAR"},
        ],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(blob)}],
        "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
    }
    return json.dumps(doc).encode()


def test_a_draco_upload_decodes_to_the_same_mesh() -> None:
    doc = GltfDocument.from_bytes(_draco_gltf(CAPSULE))
    assert "extensionsRequired" not in doc.json or doc.json["extensionsRequired"] == []
    mesh = ingest(_draco_gltf(CAPSULE), "gltf")
    assert len(mesh.vertices) == len(CAPSULE.vertices) and len(mesh.faces) == len(CAPSULE.faces)
    np.testing.assert_allclose(mesh.vertices, CAPSULE.vertices, atol=2e-4)  # 14-bit quantisation, order kept
    np.testing.assert_array_equal(mesh.faces, CAPSULE.faces)


def test_a_draco_upload_is_rigged_and_its_export_validates(tmp_path: Path) -> None:
    source = tmp_path / "capsule.gltf"
    source.write_bytes(_draco_gltf(CAPSULE))
    state = run_pipeline(PipelineInputs(source, "gltf"), JobOptions(), tmp_path / "out")  # export validates or raises
    assert {"rigged.glb", "rigged.usdc"} <= set(state.artifacts)
    exported = GltfDocument.from_bytes(state.artifacts["rigged.glb"].read_bytes())
    assert "KHR_draco_mesh_compression" not in json.dumps(exported.json)


def test_corrupt_draco_data_is_a_clear_error() -> None:
    with pytest.raises(InvalidInput) as err:
        GltfDocument.from_bytes(_draco_gltf(CAPSULE, payload=b"DRACO" + bytes(64)))
    assert err.value.code == "invalid_gltf" and "Draco" in str(err.value)


def test_meshopt_compression_is_refused_by_name() -> None:
    data = json.loads(_draco_gltf(CAPSULE))
    data["meshes"][0]["primitives"][0].pop("extensions")
    data["extensionsUsed"] = data["extensionsRequired"] = ["EXT_meshopt_compression"]
    with pytest.raises(UnsupportedFormat) as err:
        GltfDocument.from_bytes(json.dumps(data).encode())
    assert err.value.code == "unsupported_format" and "EXT_meshopt_compression" in str(err.value)


def test_a_draco_point_cloud_under_an_indexed_primitive_is_a_clear_error() -> None:
    data = json.loads(_draco_gltf(CAPSULE, payload=DracoPy.encode(CAPSULE.vertices.astype(np.float32))))
    prim = data["meshes"][0]["primitives"][0]
    del prim["attributes"]["NORMAL"], prim["extensions"]["KHR_draco_mesh_compression"]["attributes"]["NORMAL"]
    with pytest.raises(InvalidInput) as err:
        GltfDocument.from_bytes(json.dumps(data).encode())
    assert "point cloud" in str(err.value)
