"""Small studio-like rigged glTF files built in tests: a textured capsule on a hips → spine → head chain, an
optional sword bone as a second skin root, the skin's joints in any order, images as external files or embedded."""

from __future__ import annotations

import base64
import io
import json
import struct
from typing import Any

import numpy as np
import trimesh
from PIL import Image

CHAIN = {"hips": (None, [0.0, 0.4, 0.0]), "spine": ("hips", [0.0, 0.4, 0.0]), "head": ("spine", [0.0, 0.4, 0.0])}
SWORD = {"sword": (None, [0.35, 0.8, 0.0])}


def png_bytes() -> bytes:
    out = io.BytesIO()
    Image.fromarray(np.arange(48, dtype=np.uint8).reshape(4, 4, 3) * 5).save(out, format="PNG")
    return out.getvalue()


def _geometry(with_sword: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """(vertices (V, 3), faces (F, 3), uv (V, 2), owner joint name per vertex block) of the capsule (+ a blade)."""
    body = trimesh.creation.capsule(height=1.2, radius=0.15, count=[12, 12])
    body.apply_transform(trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0]))
    body.apply_translation([0, 0.8 - body.bounds[:, 1].mean(), 0])
    parts = [body]
    if with_sword:
        blade = trimesh.creation.box([0.04, 0.5, 0.04])
        blade.apply_translation([0.35, 1.05, 0.0])
        parts.append(blade)
    v = np.concatenate([p.vertices for p in parts])
    offsets = np.cumsum([0] + [len(p.vertices) for p in parts])
    f = np.concatenate([p.faces + o for p, o in zip(parts, offsets)])
    uv = np.stack([(np.arctan2(v[:, 2], v[:, 0]) / (2 * np.pi)) % 1.0, v[:, 1] / 2.0], axis=1)
    owner = ["body"] * len(body.vertices) + ["sword"] * (len(v) - len(body.vertices))
    return v, f, uv, owner


def _weights(v: np.ndarray, owner: list[str], names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """(JOINTS_0 (V, 4) uint16, WEIGHTS_0 (V, 4) float32): body vertices blend their two nearest chain joints
    by height, blade vertices follow the sword."""
    heads = {"hips": 0.4, "spine": 0.8, "head": 1.2}
    joints = np.zeros((len(v), 4), np.uint16)
    weights = np.zeros((len(v), 4), np.float32)
    for i, (p, who) in enumerate(zip(v, owner)):
        if who == "sword":
            joints[i, 0], weights[i, 0] = names.index("sword"), 1.0
            continue
        d = np.array([abs(p[1] - heads[n]) for n in ("hips", "spine", "head")])
        near = np.argsort(d)[:2]
        w = 1.0 / np.maximum(d[near], 1e-3)
        for k, (j, wk) in enumerate(zip(near, w / w.sum())):
            joints[i, k], weights[i, k] = names.index(("hips", "spine", "head")[j]), wk
    return joints, weights


def studio_rig(order: list[str], *, image_uri: str | None = None, animated: bool = False) -> dict:
    """glTF JSON (buffers as one data: URI) of the rig with skin joints listed in `order` (a subset of hips,
    spine, head, sword; "sword" adds the second root). `image_uri` gives the material's texture that URI
    (e.g. an external file name); None embeds a PNG. `animated` adds a 1 s clip bending the spine and
    swinging the sword."""
    bones = {**CHAIN, **(SWORD if "sword" in order else {})}
    v, f, uv, owner = _geometry("sword" in order)
    ji, wi = _weights(v, owner, order)
    nodes: list[dict[str, Any]] = [{"name": "character", "mesh": 0, "skin": 0}]
    node_of: dict[str, int] = {}
    for name in bones:
        node_of[name] = len(nodes)
        nodes.append({"name": name, "translation": bones[name][1]})
    for name, (parent, _) in bones.items():
        if parent:
            nodes[node_of[parent]].setdefault("children", []).append(node_of[name])
    world: dict[str, np.ndarray] = {}
    for name, (parent, t) in bones.items():
        world[name] = np.add(world[parent], t) if parent else np.asarray(t)
    ibm = np.stack([np.eye(4) for _ in order])
    for k, name in enumerate(order):
        ibm[k, :3, 3] = -world[name]
    blobs = [v.astype(np.float32).tobytes(), uv.astype(np.float32).tobytes(), ji.tobytes(), wi.tobytes(),
             f.reshape(-1).astype(np.uint32).tobytes(), ibm.transpose(0, 2, 1).astype(np.float32).tobytes()]
    kinds = [("VEC3", 5126, len(v)), ("VEC2", 5126, len(v)), ("VEC4", 5123, len(v)), ("VEC4", 5126, len(v)),
             ("SCALAR", 5125, f.size), ("MAT4", 5126, len(order))]
    channels = []
    if animated:
        times = np.array([0.0, 0.5, 1.0], np.float32)
        bend = np.array([[0, 0, 0, 1], [0, 0, np.sin(0.3), np.cos(0.3)], [0, 0, 0, 1]], np.float32)
        swing = np.array([[0, 0, 0, 1], [np.sin(0.4), 0, 0, np.cos(0.4)], [0, 0, 0, 1]], np.float32)
        lift = np.array([[0.35, 0.8, 0], [0.35, 0.9, 0], [0.35, 0.8, 0]], np.float32)
        for target, path, values in (("spine", "rotation", bend), ("sword", "rotation", swing), ("sword", "translation", lift)):
            if target in order:
                blobs += [times.tobytes(), values.tobytes()]
                kinds += [("SCALAR", 5126, 3), ("VEC4" if path == "rotation" else "VEC3", 5126, 3)]
                channels.append((node_of[target], path, len(kinds) - 2))
    offsets = np.cumsum([0] + [len(b) + (-len(b) % 4) for b in blobs])
    data = b"".join(b + b"\0" * (-len(b) % 4) for b in blobs)
    accessors = [{"bufferView": k, "componentType": c, "count": n, "type": t} for k, (t, c, n) in enumerate(kinds)]
    accessors[0] |= {"min": v.min(0).tolist(), "max": v.max(0).tolist()}
    for _, _, acc in channels:
        accessors[acc] |= {"min": [0.0], "max": [1.0]}
    image = {"uri": image_uri} if image_uri else {"uri": "data:image/png;base64," + base64.b64encode(png_bytes()).decode()}
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0] + [node_of[n] for n, (p, _) in bones.items() if p is None]}],
        "nodes": nodes,
        "skins": [{"joints": [node_of[n] for n in order], "inverseBindMatrices": 5}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1, "JOINTS_0": 2, "WEIGHTS_0": 3},
                                    "indices": 4, "material": 0}]}],
        "materials": [{"name": "skin", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
        "textures": [{"source": 0}],
        "images": [image],
        "accessors": accessors,
        "bufferViews": [{"buffer": 0, "byteOffset": int(offsets[k]), "byteLength": len(b)} for k, b in enumerate(blobs)],
        "buffers": [{"byteLength": len(data), "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
    }
    if channels:
        doc["animations"] = [{"name": "swing", "samplers": [{"input": a, "output": a + 1} for _, _, a in channels],
                              "channels": [{"sampler": k, "target": {"node": n, "path": p}} for k, (n, p, _) in enumerate(channels)]}]
    return doc


def to_glb(doc: dict) -> bytes:
    """A .gltf JSON whose only buffer is a data: URI, as a GLB with that buffer in its BIN chunk."""
    doc = json.loads(json.dumps(doc))
    blob = base64.b64decode(doc["buffers"][0].pop("uri").split(",", 1)[1])
    body = json.dumps(doc).encode()
    body += b" " * (-len(body) % 4)
    blob += b"\0" * (-len(blob) % 4)
    chunks = struct.pack("<I4s", len(body), b"JSON") + body + struct.pack("<I4s", len(blob), b"BIN\0") + blob
    return struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks


def with_accessor_values(doc: dict, accessor: int, edit) -> dict:
    """A copy of `doc` (from studio_rig) whose float32 accessor `accessor` is passed through `edit(array)`."""
    doc = json.loads(json.dumps(doc))
    blob = bytearray(base64.b64decode(doc["buffers"][0]["uri"].split(",", 1)[1]))
    view = doc["bufferViews"][doc["accessors"][accessor]["bufferView"]]
    start, end = view["byteOffset"], view["byteOffset"] + view["byteLength"]
    values = np.frombuffer(bytes(blob[start:end]), np.float32).copy()
    blob[start:end] = np.asarray(edit(values), np.float32).tobytes()
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(bytes(blob)).decode()
    return doc
