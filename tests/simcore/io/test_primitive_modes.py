"""Triangle strips and fans (glTF modes 5 and 6) are read as triangle lists with the spec's winding."""

from __future__ import annotations

import base64
import json

import numpy as np
import pytest

from simcore.ingest import ingest
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import primitive_triangles

# A 3 × 2 grid in the XY plane: two quads side by side, seen from +Z.
GRID = np.array([[0, 0, 0], [0, 1, 0], [1, 0, 0], [1, 1, 0], [2, 0, 0], [2, 1, 0]], np.float32)
STRIP = np.array([1, 0, 3, 2, 5, 4], np.uint16)  # top, bottom, top, bottom… left to right


def _gltf(indices: np.ndarray, mode: int | None) -> bytes:
    blobs = [GRID.tobytes(), indices.tobytes()]
    prim = {"attributes": {"POSITION": 0}, "indices": 1} | ({} if mode is None else {"mode": mode})
    doc = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [prim]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(GRID), "type": "VEC3",
             "min": GRID.min(0).tolist(), "max": GRID.max(0).tolist()},
            {"bufferView": 1, "componentType": 5123, "count": len(indices), "type": "SCALAR"},
        ],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(blobs[0])},
                        {"buffer": 0, "byteOffset": len(blobs[0]), "byteLength": len(blobs[1])}],
        "buffers": [{"byteLength": sum(map(len, blobs)),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(b"".join(blobs)).decode()}],
    }
    return json.dumps(doc).encode()


def _normals(faces: np.ndarray) -> np.ndarray:
    a, b, c = (GRID[faces[:, k]].astype(np.float64) for k in range(3))
    return np.cross(b - a, c - a)


def test_a_strip_gives_every_triangle_facing_the_same_way() -> None:
    doc = GltfDocument.from_bytes(_gltf(STRIP, 5))
    faces = primitive_triangles(doc, doc.items("meshes")[0]["primitives"][0], len(GRID))
    assert faces.shape == (4, 3)
    assert np.all(_normals(faces)[:, 2] > 0)  # 1,0,3 winds counter-clockwise from +Z; the odd ones must agree


def test_a_fan_turns_around_its_first_vertex() -> None:
    fan = np.array([0, 2, 3, 1], np.uint16)  # one quad as a fan around vertex 0
    doc = GltfDocument.from_bytes(_gltf(fan, 6))
    faces = primitive_triangles(doc, doc.items("meshes")[0]["primitives"][0], len(GRID))
    assert faces.tolist() == [[0, 2, 3], [0, 3, 1]]
    assert np.all(_normals(faces)[:, 2] > 0)


@pytest.mark.parametrize("mode", [5, 6])
def test_ingest_keeps_strip_and_fan_meshes(mode: int) -> None:
    indices = STRIP if mode == 5 else np.array([2, 3, 1, 0], np.uint16)
    mesh = ingest(_gltf(indices, mode), "gltf")
    assert len(mesh.faces) == (4 if mode == 5 else 2)  # was refused: "the mesh has no triangles"
    assert len(mesh.vertices) == len(GRID)
