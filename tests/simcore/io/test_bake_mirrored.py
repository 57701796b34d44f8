"""A mirrored node (negative scale, common for the second half of a symmetric model) must not turn its mesh inside out."""

from __future__ import annotations

import base64
import json

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from simcore.ingest import ingest
from simcore.io.gltf_document import GltfDocument
from tests.simcore.io.rig_export_fixtures import capsule_glb, glb_with_json
from tests.simcore.io.studio_rig_fixtures import studio_rig, to_glb


@pytest.mark.parametrize("scale", [[-1.0, 1.0, 1.0], [-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]])
def test_baked_triangles_keep_facing_outwards(scale: list[float]) -> None:
    def place(doc: dict) -> None:
        for node in doc["nodes"]:
            if "mesh" in node:
                node["scale"] = scale

    mesh = ingest(glb_with_json(capsule_glb()[0], place), "glb")
    solid = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    assert solid.volume > 0  # outward winding: negative for an inside-out mesh



def _triangle_gltf(scale: list[float]) -> bytes:
    """One triangle with normals and tangents (w = +1) under a node with `scale`."""
    pos = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=np.float32)
    normals = np.array([[0, 0, 1]] * 3, dtype=np.float32)
    tangents = np.array([[1, 0, 0, 1]] * 3, dtype=np.float32)
    blobs = [pos.tobytes(), normals.tobytes(), tangents.tobytes()]
    offsets = np.cumsum([0] + [len(b) for b in blobs])
    doc = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "scale": scale}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TANGENT": 2}}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
                      {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"},
                      {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC4"}],
        "bufferViews": [{"buffer": 0, "byteOffset": int(offsets[k]), "byteLength": len(b)} for k, b in enumerate(blobs)],
        "buffers": [{"byteLength": int(offsets[-1]), "uri": "data:application/octet-stream;base64," + base64.b64encode(b"".join(blobs)).decode()}],
    }
    return json.dumps(doc).encode()


@pytest.mark.parametrize(("scale", "sign"), [([-1.0, 1.0, 1.0], -1.0), ([1.0, 1.0, 1.0], 1.0)])
def test_a_mirror_flips_the_tangent_handedness(scale: list[float], sign: float) -> None:
    mesh = ingest(_triangle_gltf(scale), "gltf")
    doc = GltfDocument.from_bytes(mesh.glb)
    prim = doc.json["meshes"][0]["primitives"][0]
    np.testing.assert_array_equal(doc.accessor(prim["attributes"]["TANGENT"])[:, 3], [sign] * 3)
    normal = doc.accessor(prim["attributes"]["NORMAL"])[0]
    a, b, c = mesh.vertices[mesh.faces[0]]
    assert np.dot(np.cross(b - a, c - a), normal) > 0  # winding and normal still agree


def test_a_mirrored_joint_keeps_a_proper_bind_rotation() -> None:
    """A joint node with a negative scale (a mirrored limb) has a left-handed frame: the source rig keeps the
    nearest proper rotation instead of failing the upload."""
    doc = studio_rig(["hips", "spine", "head"])
    head = next(n for n in doc["nodes"] if n["name"] == "head")
    head["scale"] = [-1.0, 1.0, 1.0]
    rig = ingest(to_glb(doc), "glb").source_rig
    assert rig is not None and rig.skeleton.orientations is not None
    np.testing.assert_allclose(np.linalg.norm(rig.skeleton.orientations, axis=1), 1.0, atol=1e-9)
    frames = Rotation.from_quat(rig.skeleton.orientations).as_matrix()
    np.testing.assert_allclose(np.linalg.det(frames), 1.0, atol=1e-9)
    np.testing.assert_allclose(rig.skeleton.positions[rig.skeleton.names.index("head"), 1], 1.2, atol=1e-6)
