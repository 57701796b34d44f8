"""glTF animation writing: joint rotation/translation channels and refinement morph-target weights.

Morph scheme (refined.glb): one morph target per keyed frame, each holding that frame's bind-space
offset from the skinned animation. A clip of T ≤ `max_targets` frames keys every frame with one-hot
weights and a STEP sampler. Longer clips key `max_targets` frames spread uniformly over the clip and
use a LINEAR sampler, so the offsets blend between neighbouring keys. The default cap of 256 is the
smallest MAX_ARRAY_TEXTURE_LAYERS WebGL 2 guarantees, which three.js uses for morph target textures.
"""

from __future__ import annotations

import numpy as np

from simcore.io.glb_packer import GlbBuilder
from simcore.io.joint_tracks import joint_tracks
from simcore.motion.types import JointAnimation
from simcore.skeleton.kinematics import rest_local_matrices
from simcore.skeleton.types import Skeleton

TRANSLATION_EPS = 1e-6  # metres: a non-root joint whose translation track stays this close to rest gets no channel


def _sampler(builder: GlbBuilder, clip: dict, times: np.ndarray, values: np.ndarray, interpolation: str) -> int:
    sampler = {
        "input": builder.add_accessor(times.astype(np.float32), minmax=True),
        "output": builder.add_accessor(np.ascontiguousarray(values, dtype=np.float32)),
        "interpolation": interpolation,
    }
    clip["samplers"].append(sampler)
    return len(clip["samplers"]) - 1


def add_joint_animation(builder: GlbBuilder, skeleton: Skeleton, animation: JointAnimation, joint_base: int) -> dict:
    """Write rotation channels for every clip joint and translation channels for the root and any joint
    whose translation leaves its rest value; return the glTF animation object (not yet attached).

    joint_base: node index of joint 0 (joints are consecutive nodes in skeleton order).
    """
    tracks = joint_tracks(skeleton, animation)
    clip: dict = {"name": animation.name, "channels": [], "samplers": []}
    times_acc = builder.add_accessor(tracks.times.astype(np.float32), minmax=True)
    rest_local = rest_local_matrices(skeleton)[:, :3, 3]
    for j in np.flatnonzero(tracks.animated):
        rot = tracks.rotations[:, j].astype(np.float32)
        rot /= np.linalg.norm(rot, axis=1, keepdims=True)  # unit length in float32, as the validator checks
        channels = [("rotation", rot)]
        moved = np.abs(tracks.translations[:, j] - rest_local[j]).max() > TRANSLATION_EPS
        if skeleton.parents[j] < 0 or moved:
            channels.append(("translation", tracks.translations[:, j]))
        for path, values in channels:
            clip["samplers"].append({
                "input": times_acc,
                "output": builder.add_accessor(np.ascontiguousarray(values, dtype=np.float32)),
                "interpolation": "LINEAR",
            })
            clip["channels"].append({"sampler": len(clip["samplers"]) - 1,
                                     "target": {"node": joint_base + int(j), "path": path}})
    return clip


def morph_key_frames(frame_count: int, max_targets: int) -> np.ndarray:
    """(K,) int64 frames that get a morph target: all of them, or `max_targets` spread uniformly."""
    if frame_count <= max_targets:
        return np.arange(frame_count)
    return np.unique(np.round(np.linspace(0, frame_count - 1, max_targets)).astype(np.int64))


def add_morph_animation(builder: GlbBuilder, clip: dict, slices: list, offsets: np.ndarray, fps: float,
                        max_targets: int = 256) -> dict:
    """Add one POSITION morph target per keyed frame to every primitive and a weights channel per mesh node.

    slices:  PrimitiveSlice list (mesh, primitive, start, count) in vertex order; mesh m's node is node m.
    offsets: (T, V, 3) float bind-space vertex offsets, frame k at time k / fps.
    The upload's own targets (blend shapes) stay first and keep their default weights throughout the clip.
    Returns JSON-ready stats (targets, interpolation, max offset).
    """
    frames = morph_key_frames(len(offsets), max_targets)
    k = len(frames)
    meshes = builder.json["meshes"]
    for s in slices:
        prim = meshes[s.mesh]["primitives"][s.primitive]
        part = offsets[frames, s.start:s.start + s.count].astype(np.float32)
        prim["targets"] = prim.get("targets", []) + [{"POSITION": builder.add_accessor(part[i], minmax=True)} for i in range(k)]
    names = [f"frame_{int(f)}" for f in frames]
    interpolation = "STEP" if k == len(offsets) else "LINEAR"
    times = frames / float(fps)
    for m in sorted({s.mesh for s in slices}):
        own = [float(w) for w in meshes[m].get("weights", [])]
        own_names = meshes[m].get("extras", {}).get("targetNames", [])  # ingest names every upload target
        meshes[m]["weights"] = own + [0.0] * k
        meshes[m].setdefault("extras", {})["targetNames"] = own_names + names  # three.js morphTargetDictionary keys
        # keyframe i shows refinement target i alone, the upload's own shapes at their defaults
        weights = np.hstack([np.tile(np.asarray(own, np.float32), (k, 1)), np.eye(k, dtype=np.float32)]).reshape(-1)
        sampler = _sampler(builder, clip, times, weights, interpolation)
        clip["channels"].append({"sampler": sampler, "target": {"node": m, "path": "weights"}})
    return {"targets": k, "frames": int(len(offsets)), "interpolation": interpolation,
            "max_offset": float(np.abs(offsets).max(initial=0.0))}
