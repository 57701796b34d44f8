"""Small generated rigs for the exporter tests (a textured capsule, a joint chain along it, smooth weights) and
glTF builders (a GLB with its JSON edited, a Draco-compressed .gltf)."""

from __future__ import annotations

import base64
import json
import struct

import DracoPy
import numpy as np
import scipy.sparse as sp
import trimesh
from PIL import Image

from simcore.motion.types import JointAnimation
from simcore.skeleton.types import Skeleton


def capsule_glb(height: float = 0.8, radius: float = 0.1, textured: bool = True) -> tuple[bytes, trimesh.Trimesh]:
    """mesh.glb of a +Y capsule with normals and, when `textured`, cylindrical UVs and a 4x4 PNG base-colour texture."""
    mesh = trimesh.creation.capsule(height=height, radius=radius, count=[12, 12])
    mesh.apply_transform(trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0]))
    if not textured:
        return trimesh.exchange.gltf.export_glb(trimesh.Scene(mesh), include_normals=True), mesh
    v = mesh.vertices
    uv = np.stack([(np.arctan2(v[:, 2], v[:, 0]) / (2 * np.pi)) % 1.0, (v[:, 1] - v[:, 1].min()) / np.ptp(v[:, 1])], 1)
    image = Image.fromarray(np.arange(48, dtype=np.uint8).reshape(4, 4, 3) * 5)
    mesh.visual = trimesh.visual.TextureVisuals(uv=uv, material=trimesh.visual.material.PBRMaterial(
        baseColorTexture=image, baseColorFactor=[200, 180, 160, 255]))
    data = trimesh.exchange.gltf.export_glb(trimesh.Scene(mesh), include_normals=True)
    return data, mesh


def glb_with_json(data: bytes, edit) -> bytes:
    """The GLB `data` with its JSON chunk passed through `edit(doc)` (in place); the BIN chunk is kept."""
    json_len = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + json_len])
    edit(doc)
    body = json.dumps(doc).encode()
    body += b" " * (-len(body) % 4)
    rest = data[20 + json_len:]
    return struct.pack("<4sII", b"glTF", 2, 20 + len(body) + len(rest)) + struct.pack("<I4s", len(body), b"JSON") + body + rest


def chain_skeleton(joints: int, height: float = 0.8) -> Skeleton:
    """A straight chain of `joints` joints from y = -height/2 (root) to +height/2."""
    y = np.linspace(-height / 2, height / 2, joints)
    positions = np.stack([np.zeros(joints), y, np.zeros(joints)], 1)
    return Skeleton(positions, np.arange(joints) - 1, [f"joint_{j}" for j in range(joints)])


def falloff_weights(vertices: np.ndarray, skeleton: Skeleton, keep: int, width: float = 0.1) -> sp.csr_matrix:
    """(V, J) weights ∝ exp(-|Δy| / width), keeping the `keep` largest per vertex, rows summing to 1."""
    d = np.abs(vertices[:, 1:2] - skeleton.positions[None, :, 1])
    w = np.exp(-d / width)
    w[w < np.sort(w, axis=1)[:, -keep][:, None]] = 0.0
    return sp.csr_matrix(w / w.sum(axis=1, keepdims=True))


def bend_animation(skeleton: Skeleton, frames: int = 12, fps: float = 24.0) -> JointAnimation:
    """Every non-root joint bends about z up to 30°, the root slides along x."""
    angle = np.linspace(0, np.deg2rad(30), frames)
    rot = np.zeros((frames, skeleton.num_joints, 4))
    rot[..., 3] = 1.0
    rot[:, 1:, 2] = np.sin(angle / 2)[:, None]
    rot[:, 1:, 3] = np.cos(angle / 2)[:, None]
    trans = np.zeros((frames, skeleton.num_joints, 3))
    trans[:, 0] = skeleton.positions[0]
    trans[:, 1:] = skeleton.positions[1:] - skeleton.positions[skeleton.parents[1:]]
    trans[:, 0, 0] += np.linspace(0, 0.2, frames)
    return JointAnimation(list(skeleton.names), fps, rot, trans, name="bend")


def draco_gltf(mesh: trimesh.Trimesh, *, payload: bytes | None = None, required: str = "KHR_draco_mesh_compression") -> bytes:
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
