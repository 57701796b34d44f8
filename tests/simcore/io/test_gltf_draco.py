"""Draco-compressed glTF uploads decode to the same mesh; meshopt-compressed ones are refused by name."""

from __future__ import annotations

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
from tests.simcore.io.rig_export_fixtures import draco_gltf

CAPSULE = trimesh.creation.capsule(height=0.8, radius=0.15, count=[12, 12])


def test_a_draco_upload_decodes_to_the_same_mesh() -> None:
    doc = GltfDocument.from_bytes(draco_gltf(CAPSULE))
    assert "extensionsRequired" not in doc.json or doc.json["extensionsRequired"] == []
    mesh = ingest(draco_gltf(CAPSULE), "gltf")
    assert len(mesh.vertices) == len(CAPSULE.vertices) and len(mesh.faces) == len(CAPSULE.faces)
    np.testing.assert_allclose(mesh.vertices, CAPSULE.vertices, atol=2e-4)  # 14-bit quantisation, order kept
    np.testing.assert_array_equal(mesh.faces, CAPSULE.faces)


def test_a_draco_upload_is_rigged_and_its_export_validates(tmp_path: Path) -> None:
    source = tmp_path / "capsule.gltf"
    source.write_bytes(draco_gltf(CAPSULE))
    state = run_pipeline(PipelineInputs(source, "gltf"), JobOptions(), tmp_path / "out")  # export validates or raises
    assert {"rigged.glb", "rigged.usdc"} <= set(state.artifacts)
    exported = GltfDocument.from_bytes(state.artifacts["rigged.glb"].read_bytes())
    assert "KHR_draco_mesh_compression" not in json.dumps(exported.json)


def test_corrupt_draco_data_is_a_clear_error() -> None:
    with pytest.raises(InvalidInput) as err:
        GltfDocument.from_bytes(draco_gltf(CAPSULE, payload=b"DRACO" + bytes(64)))
    assert err.value.code == "invalid_gltf" and "Draco" in str(err.value)


def test_meshopt_compression_is_refused_by_name() -> None:
    data = json.loads(draco_gltf(CAPSULE))
    data["meshes"][0]["primitives"][0].pop("extensions")
    data["extensionsUsed"] = data["extensionsRequired"] = ["EXT_meshopt_compression"]
    with pytest.raises(UnsupportedFormat) as err:
        GltfDocument.from_bytes(json.dumps(data).encode())
    assert err.value.code == "unsupported_format" and "EXT_meshopt_compression" in str(err.value)


def test_a_draco_point_cloud_under_an_indexed_primitive_is_a_clear_error() -> None:
    data = json.loads(draco_gltf(CAPSULE, payload=DracoPy.encode(CAPSULE.vertices.astype(np.float32))))
    prim = data["meshes"][0]["primitives"][0]
    del prim["attributes"]["NORMAL"], prim["extensions"]["KHR_draco_mesh_compression"]["attributes"]["NORMAL"]
    with pytest.raises(InvalidInput) as err:
        GltfDocument.from_bytes(json.dumps(data).encode())
    assert "point cloud" in str(err.value)

