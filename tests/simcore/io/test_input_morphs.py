"""An upload's own morph targets (blend shapes) survive ingest, the rigged GLB, its refinement bake and USD."""

from __future__ import annotations

import base64
import json
from pathlib import Path

import numpy as np
import pytest
import trimesh

from simcore.ingest import ingest
from simcore.io.glb_rig_writer import write_rigged_glb
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_validate import validate_gltf_file
from simcore.options import JobOptions
from simcore.pipeline import PipelineInputs, run_pipeline
from tests.simcore.io.rig_export_fixtures import bend_animation, chain_skeleton, falloff_weights

CAPSULE = trimesh.creation.capsule(height=0.8, radius=0.1, count=[12, 12])
QUARTER_Z = [0.0, 0.0, float(np.sin(np.pi / 4)), float(np.cos(np.pi / 4))]  # the node turns +X onto +Y
R = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


def _gltf_with_shapes() -> tuple[bytes, np.ndarray, np.ndarray]:
    """A capsule lying along X (a node turns it upright) with targets "smile" (bulge) and "shift" (+X)."""
    pos = (CAPSULE.vertices @ R).astype(np.float32)  # R @ pos_file = capsule upright
    normals = (CAPSULE.vertex_normals @ R).astype(np.float32)
    bulge = (0.05 * normals * (pos[:, :1] > 0)).astype(np.float32)
    shift = np.tile(np.array([0.05, 0.0, 0.0], dtype=np.float32), (len(pos), 1))
    faces = CAPSULE.faces.astype(np.uint32).reshape(-1)
    blobs = [pos.tobytes(), normals.tobytes(), faces.tobytes(), bulge.tobytes(), shift.tobytes()]
    offsets = np.cumsum([0] + [len(b) for b in blobs])
    vec3 = {"componentType": 5126, "count": len(pos), "type": "VEC3"}
    accessors = [vec3 | {"bufferView": 0, "min": pos.min(0).tolist(), "max": pos.max(0).tolist()}, vec3 | {"bufferView": 1},
                 {"bufferView": 2, "componentType": 5125, "count": len(faces), "type": "SCALAR"},
                 vec3 | {"bufferView": 3, "min": bulge.min(0).tolist(), "max": bulge.max(0).tolist()},
                 vec3 | {"bufferView": 4, "min": shift.min(0).tolist(), "max": shift.max(0).tolist()}]
    doc = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "rotation": QUARTER_Z}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2,
                                    "targets": [{"POSITION": 3}, {"POSITION": 4}]}],
                    "weights": [0.0, 0.25], "extras": {"targetNames": ["smile", "shift"]}}],
        "accessors": accessors,
        "bufferViews": [{"buffer": 0, "byteOffset": int(offsets[k]), "byteLength": len(b)} for k, b in enumerate(blobs)],
        "buffers": [{"byteLength": int(offsets[-1]), "uri": "data:application/octet-stream;base64," + base64.b64encode(b"".join(blobs)).decode()}],
    }
    return json.dumps(doc).encode(), bulge, shift


@pytest.fixture(scope="module")
def ingested():
    data, bulge, shift = _gltf_with_shapes()
    return ingest(data, "gltf"), bulge, shift


def test_ingest_keeps_the_shapes_turned_with_their_mesh(ingested) -> None:
    mesh, bulge, shift = ingested
    doc = GltfDocument.from_bytes(mesh.glb)
    gltf_mesh = doc.json["meshes"][0]
    targets = gltf_mesh["primitives"][0]["targets"]
    assert len(targets) == 2 and gltf_mesh["weights"] == [0.0, 0.25]
    assert gltf_mesh["extras"]["targetNames"] == ["smile", "shift"]
    np.testing.assert_allclose(doc.accessor(targets[0]["POSITION"]), bulge @ R.T, atol=1e-6)
    np.testing.assert_allclose(doc.accessor(targets[1]["POSITION"]), np.tile([0.0, 0.05, 0.0], (len(shift), 1)), atol=1e-6)


def test_refinement_targets_follow_the_uploads_own(ingested, tmp_path: Path) -> None:
    mesh, *_ = ingested
    skeleton = chain_skeleton(3)
    weights = falloff_weights(mesh.vertices, skeleton, keep=2)
    animation = bend_animation(skeleton, frames=4)
    refined = np.repeat(mesh.vertices[None], 4, axis=0)
    path = tmp_path / "refined.glb"
    export = write_rigged_glb(mesh.glb, skeleton, weights, animation=animation, morph_frames=refined, out_path=path)
    result = validate_gltf_file(path)
    assert result.errors == 0, result.messages
    doc = GltfDocument.from_bytes(export.data)
    gltf_mesh = doc.json["meshes"][0]
    ours = export.stats["morph"]["targets"]
    assert ours > 0 and len(gltf_mesh["primitives"][0]["targets"]) == 2 + ours
    assert gltf_mesh["extras"]["targetNames"][:2] == ["smile", "shift"]
    assert gltf_mesh["weights"] == [0.0, 0.25] + [0.0] * ours
    channel = next(c for c in doc.json["animations"][0]["channels"] if c["target"]["path"] == "weights")
    keys = doc.accessor(doc.json["animations"][0]["samplers"][channel["sampler"]]["output"]).reshape(4, 2 + ours)
    np.testing.assert_array_equal(keys[:, :2], [[0.0, 0.25]] * 4)  # the upload's shapes hold their defaults


def test_a_job_exports_the_shapes_to_glb_and_usd(tmp_path: Path) -> None:
    from pxr import Usd, UsdSkel

    source = tmp_path / "shapes.gltf"
    source.write_bytes(_gltf_with_shapes()[0])
    state = run_pipeline(PipelineInputs(source, "gltf"), JobOptions(), tmp_path / "out")  # both exports validate
    rigged = GltfDocument.from_bytes(state.artifacts["rigged.glb"].read_bytes())
    assert len(rigged.json["meshes"][0]["primitives"][0]["targets"]) == 2
    stage = Usd.Stage.Open(str(state.artifacts["rigged.usdc"]))
    shapes = [p for p in stage.Traverse() if p.IsA(UsdSkel.BlendShape)]
    assert sorted(p.GetName() for p in shapes) == ["shift", "smile"]
    mesh_prim = shapes[0].GetParent()
    assert list(UsdSkel.BindingAPI(mesh_prim).GetBlendShapesAttr().Get()) == ["smile", "shift"]
    offsets = np.asarray(UsdSkel.BlendShape(stage.GetPrimAtPath(mesh_prim.GetPath().AppendChild("shift"))).GetOffsetsAttr().Get())
    np.testing.assert_allclose(offsets, np.tile([0.0, 0.05, 0.0], (len(offsets), 1)), atol=1e-6)


def test_unnamed_targets_get_names_and_default_weights() -> None:
    from simcore.io.input_morphs import target_defaults

    assert target_defaults({}, {}, 2) == {"weights": [0.0, 0.0], "extras": {"targetNames": ["shape_0", "shape_1"]}}
    assert target_defaults({"weights": [0.5, 0.1]}, {"weights": [1.0, 0.0]}, 2)["weights"] == [1.0, 0.0]  # node wins
