"""Read a morph-target animation (a deforming mesh sequence, no skin) from a glTF document into frames."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simcore.errors import InvalidInput
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import primitive_triangles


@dataclass
class MeshSequence:
    """frames: (T, V, 3) float64 world positions sampled at `fps` from the clip start; faces: (F, 3) int64."""

    frames: np.ndarray
    faces: np.ndarray
    fps: float
    name: str


def _sample_track(times: np.ndarray, values: np.ndarray, interpolation: str, at: np.ndarray) -> np.ndarray:
    """(K, W) morph weights at times `at` from keyframes times (N,) and values (N, W) (CUBICSPLINE: (N, 3, W))."""
    if interpolation == "CUBICSPLINE":
        values = values.reshape(len(times), 3, -1)[:, 1]  # keep the value, drop the tangents
    idx = np.clip(np.searchsorted(times, at, side="right") - 1, 0, len(times) - 1)
    if interpolation == "STEP" or len(times) == 1:
        return values[idx]
    nxt = np.minimum(idx + 1, len(times) - 1)
    span = np.where(nxt > idx, times[nxt] - times[idx], 1.0)
    a = np.clip((at - times[idx]) / span, 0.0, 1.0)[:, None]
    return (1.0 - a) * values[idx] + a * values[nxt]


def read_morph_sequence(doc: GltfDocument, fps: float | None = None, max_frames: int | None = None,
                        animation: int = 0) -> MeshSequence:
    """Frames of the first mesh node animated by a `weights` channel of animation `animation`.

    fps: sampling rate (default: the keyframe rate of the track); all primitives of the mesh are concatenated.
    """
    anims = doc.items("animations")
    if not anims or animation >= len(anims):
        raise InvalidInput("the file has no animation to read a mesh sequence from", code="no_mesh_sequence", field="mesh")
    anim = anims[animation]
    channel = next((c for c in anim.get("channels", []) if c.get("target", {}).get("path") == "weights"), None)
    if channel is None or "node" not in channel["target"]:
        raise InvalidInput("the animation has no morph-weight channel", code="no_mesh_sequence", field="mesh")
    node_index = int(channel["target"]["node"])
    node = doc.items("nodes")[node_index]
    if "mesh" not in node:
        raise InvalidInput("the morph-weight channel targets a node without a mesh", code="no_mesh_sequence", field="mesh")
    sampler = anim["samplers"][channel["sampler"]]
    times = doc.accessor(sampler["input"]).reshape(-1).astype(np.float64)
    mesh = doc.items("meshes")[int(node["mesh"])]
    count = len(mesh["primitives"][0].get("targets", []))
    if count == 0:
        raise InvalidInput("the animated mesh has no morph targets", code="no_mesh_sequence", field="mesh")
    values = doc.accessor(sampler["output"]).reshape(-1, count).astype(np.float64)
    if fps is None:
        fps = 1.0 / float(np.median(np.diff(times))) if len(times) > 1 else 25.0
    at = times[0] + np.arange(int(np.floor((times[-1] - times[0]) * fps + 1e-6)) + 1) / fps
    if max_frames is not None:
        at = at[:max_frames]
    w = _sample_track(times, values, sampler.get("interpolation", "LINEAR"), at)  # (T, K)

    frames, faces, offset = [], [], 0
    for prim in mesh["primitives"]:
        base = doc.accessor(prim["attributes"]["POSITION"]).astype(np.float64)
        deltas = np.stack([doc.accessor(t["POSITION"]).astype(np.float64) for t in prim["targets"]])  # (K, V, 3)
        frames.append(base[None] + np.einsum("tk,kvc->tvc", w, deltas))
        faces.append(primitive_triangles(doc, prim, len(base)) + offset)
        offset += len(base)
    world = doc.world_matrices()[node_index]
    pos = np.concatenate(frames, axis=1) @ world[:3, :3].T + world[:3, 3]
    return MeshSequence(pos, np.concatenate(faces), float(fps), str(anim.get("name", "clip")))
