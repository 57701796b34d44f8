"""Mesh sequences with a known skeleton: a rigged asset posed by LBS with the artist's weights.

Motions: the asset's own clip (as `rigforge eval motion` reads it), or a seeded random motion (every joint
turning smoothly about its own random axis), for rigs without a clip or sequences in no file.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial.transform import Rotation

from simcore.evaluation.motion_eval import world_bind
from simcore.io.bind_pose import bind_placement
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import RiggedAsset, used_joints
from simcore.metrics.skeleton import used_skeleton
from simcore.motion.gltf_clips import read_gltf_clip
from simcore.motion.quality import skin_matrices
from simcore.skeleton.types import Skeleton
from simcore.skinning.lbs import linear_blend


@dataclass
class PosedSequence:
    """rest: (V, 3) bind pose in metres; faces: (F, 3); frames: (T, V, 3); truth: the artist's used joints."""

    rest: np.ndarray
    faces: np.ndarray
    frames: np.ndarray
    fps: float
    truth: Skeleton
    motion: str


def _even(count: int, limit: int) -> np.ndarray:
    return np.unique(np.linspace(0, count - 1, min(count, limit)).astype(np.int64))


def clip_sequence(doc: GltfDocument, asset: RiggedAsset, max_frames: int) -> PosedSequence:
    """The asset's first clip, at most `max_frames` frames evenly spread over it."""
    clip = read_gltf_clip(doc, None, asset=asset)
    rest, clip = world_bind(doc, asset, clip)
    mats = skin_matrices(clip.skeleton, clip.animation)
    keep = _even(len(mats), max_frames)
    frames = linear_blend(rest, asset.weights, mats[keep])
    fps = clip.animation.fps * (len(keep) - 1) / max(len(mats) - 1, 1) if len(keep) > 1 else clip.animation.fps
    truth = used_skeleton(clip.skeleton, used_joints(clip.skeleton, asset.weights))
    return PosedSequence(rest, asset.faces, frames, fps, truth, f"clip {clip.animation.name}")


def random_motion(skeleton: Skeleton, frames: int, seed: int, amplitude_deg: float = 30.0) -> np.ndarray:
    """(T, J, 4, 4) skinning matrices: each joint turns about a random axis through its rest position by
    amplitude × sin(phase + 2π f t), f of 0.5–1.5 cycles over the sequence; the root stays."""
    rng = np.random.default_rng(seed)
    count = skeleton.num_joints
    axes = rng.normal(size=(count, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    phase, cycles = rng.uniform(0, 2 * np.pi, count), rng.uniform(0.5, 1.5, count)
    t = np.linspace(0.0, 1.0, frames)[:, None]
    angle = np.radians(amplitude_deg) * np.sin(phase + 2 * np.pi * cycles * t)  # (T, J)
    angle[:, skeleton.parents < 0] = 0.0
    rot = Rotation.from_rotvec((angle[..., None] * axes).reshape(-1, 3)).as_matrix().reshape(frames, count, 3, 3)
    local = np.tile(np.eye(4), (frames, count, 1, 1))
    local[:, :, :3, :3] = rot
    local[:, :, :3, 3] = skeleton.positions - np.einsum("tjab,jb->tja", rot, skeleton.positions)
    world = local.copy()
    for j, p in enumerate(skeleton.parents.tolist()):  # parents first
        if p >= 0:
            world[:, j] = world[:, p] @ local[:, j]
    return world


def random_sequence(doc: GltfDocument, asset: RiggedAsset, frames: int, seed: int) -> PosedSequence:
    """The asset posed by `random_motion` of its own skeleton, in the frame viewers show it (metres)."""
    g = bind_placement(doc, asset)
    rest = asset.vertices @ g[:3, :3].T + g[:3, 3]
    scale = 0.01 if np.ptp(rest, axis=0).max() > 20.0 else 1.0  # as world_bind sizes centimetre files
    rest = rest * scale
    joints = (asset.skeleton.positions @ g[:3, :3].T + g[:3, 3]) * scale
    skeleton = Skeleton(joints, asset.skeleton.parents, asset.skeleton.names)
    weights = sp.csr_matrix(asset.weights)
    posed = linear_blend(rest, weights, random_motion(skeleton, frames, seed))
    truth = used_skeleton(skeleton, used_joints(skeleton, weights))
    return PosedSequence(rest, asset.faces, posed, 30.0, truth, f"random seed {seed}")


def tube_sequence(rings: int, around: int, joints: int, frames: int, seed: int = 0) -> PosedSequence:
    """A closed-ring tube along +X (length 1 m, radius 0.06 m) of rings × around vertices, skinned to a chain of
    `joints` joints with linear blends between neighbours, posed by `random_motion` over `frames` frames."""
    x = np.linspace(0.0, 1.0, rings)
    theta = np.linspace(0.0, 2 * np.pi, around, endpoint=False)
    rest = np.stack(np.broadcast_arrays(x[:, None], 0.06 * np.cos(theta)[None], 0.06 * np.sin(theta)[None]), -1)
    rest = rest.reshape(-1, 3)
    ring = np.arange(rings - 1)[:, None] * around
    a = ring + np.arange(around)[None]
    b = ring + (np.arange(around)[None] + 1) % around
    faces = np.concatenate([np.stack([a, b, a + around], -1), np.stack([b, b + around, a + around], -1)]).reshape(-1, 3)
    heads = np.linspace(0.0, 1.0, joints, endpoint=False)
    skeleton = Skeleton(np.stack([heads, np.zeros(joints), np.zeros(joints)], 1), np.arange(joints) - 1,
                        [f"j{i}" for i in range(joints)])
    spacing = 1.0 / joints
    at = np.clip((rest[:, 0] - heads[0]) / spacing - 0.5, 0.0, joints - 1.0)  # blend between bone middles
    low = np.minimum(np.floor(at).astype(np.int64), joints - 2) if joints > 1 else np.zeros(len(rest), np.int64)
    frac = at - low
    rows = np.repeat(np.arange(len(rest)), 2)
    cols = np.stack([low, np.minimum(low + 1, joints - 1)], 1).reshape(-1)
    weights = sp.csr_matrix((np.stack([1 - frac, frac], 1).reshape(-1), (rows, cols)), shape=(len(rest), joints))
    posed = linear_blend(rest, weights, random_motion(skeleton, frames, seed))
    return PosedSequence(rest, faces.astype(np.int64), posed, 30.0, skeleton, f"random seed {seed}")
