"""read_rigged_asset: meshes rigidly parented under a joint belong to the rig, in bind space, with weight 1."""

from __future__ import annotations

import base64
import json
from typing import Any

import numpy as np
import pytest

from simcore.errors import InvalidInput
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import read_rigged_asset

TRIANGLE = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0]], np.float32)


def _robot_gltf(rigid_parent: int | None) -> bytes:
    """Two joints (0 at the origin, 1 at +1 y, posed 90° about z away from its bind), a skinned triangle on
    joint 0, and an unskinned triangle 0.5 along +x from node `rigid_parent` (None = a scene root)."""
    ibm = np.stack([np.eye(4), np.eye(4)])
    ibm[1, 1, 3] = -1.0  # inverse of the bind translation (0, 1, 0)
    joints = np.array([[0, 0, 0, 0]] * 3, np.uint16)
    weights = np.array([[1, 0, 0, 0]] * 3, np.float32)
    blobs = [TRIANGLE.tobytes(), joints.tobytes(), weights.tobytes(),
             ibm.transpose(0, 2, 1).astype(np.float32).tobytes(), TRIANGLE.tobytes()]
    offsets = np.cumsum([0] + [len(b) for b in blobs])
    kinds = [("VEC3", 5126, 3), ("VEC4", 5123, 3), ("VEC4", 5126, 3), ("MAT4", 5126, 2), ("VEC3", 5126, 3)]
    accessors = [{"bufferView": k, "componentType": c, "count": n, "type": t} for k, (t, c, n) in enumerate(kinds)]
    for k in (0, 4):
        accessors[k] |= {"min": TRIANGLE.min(0).tolist(), "max": TRIANGLE.max(0).tolist()}
    quarter = [0.0, 0.0, float(np.sin(np.pi / 4)), float(np.cos(np.pi / 4))]
    nodes: list[dict[str, Any]] = [
        {"name": "root", "children": [1]},
        {"name": "arm", "translation": [0, 1, 0], "rotation": quarter, "children": []},
        {"name": "body", "mesh": 0, "skin": 0},
        {"name": "part", "mesh": 1, "translation": [0.5, 0, 0]},
    ]
    scene_roots = [0, 2]
    if rigid_parent is None:
        scene_roots.append(3)
    else:
        nodes[rigid_parent].setdefault("children", []).append(3)
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": scene_roots}],
        "nodes": nodes,
        "skins": [{"joints": [0, 1], "inverseBindMatrices": 3}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "JOINTS_0": 1, "WEIGHTS_0": 2}}]},
                   {"primitives": [{"attributes": {"POSITION": 4}}]}],
        "accessors": accessors,
        "bufferViews": [{"buffer": 0, "byteOffset": int(offsets[k]), "byteLength": len(b)} for k, b in enumerate(blobs)],
        "buffers": [{"byteLength": int(offsets[-1]),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(b"".join(blobs)).decode()}],
    }
    return json.dumps(doc).encode()


def test_rigid_part_under_a_joint_joins_the_rig_in_bind_space() -> None:
    asset = read_rigged_asset(GltfDocument.from_bytes(_robot_gltf(rigid_parent=1)))
    assert asset.vertices.shape == (6, 3) and asset.faces.tolist() == [[0, 1, 2], [3, 4, 5]]
    np.testing.assert_allclose(asset.vertices[:3], TRIANGLE, atol=1e-6)
    # Joint 1 is rotated in the file's pose, but the part must sit where it would at bind: +0.5 x from (0, 1, 0).
    np.testing.assert_allclose(asset.vertices[3:], TRIANGLE + [0.5, 1.0, 0.0], atol=1e-6)
    w = asset.weights.toarray()
    np.testing.assert_allclose(w[:3], [[1, 0]] * 3)
    np.testing.assert_allclose(w[3:], [[0, 1]] * 3)


def test_mesh_outside_the_armature_is_not_part_of_the_rig() -> None:
    asset = read_rigged_asset(GltfDocument.from_bytes(_robot_gltf(rigid_parent=None)))
    assert len(asset.vertices) == 3


def test_file_without_a_skinned_mesh_is_refused() -> None:
    doc = json.loads(_robot_gltf(rigid_parent=1))
    del doc["nodes"][2]["skin"]
    with pytest.raises(InvalidInput, match="no skinned mesh"):
        read_rigged_asset(GltfDocument.from_bytes(json.dumps(doc).encode()))
