"""Refined (simulated) vertex positions → bind-space morph offsets that a skinned glTF replays exactly.

glTF applies morph targets before skinning: a viewer shows x_t = A_t(v) (p + d_t) + b_t(v), where
[A | b] is the vertex's blended skin matrix at frame t. So the offset reproducing a simulated position
y_t is d_t = A_t⁻¹ (y_t − b_t) − p, computed with the exported (top-k, float32) influences.
"""

from __future__ import annotations

import numpy as np

from simcore.errors import InvalidInput
from simcore.io.joint_tracks import joint_tracks
from simcore.io.skin_influences import Influences
from simcore.motion.types import JointAnimation
from simcore.skeleton.types import Skeleton

SINGULAR_DET = 1e-9  # blended 3x3 parts below this determinant are inverted by least squares


def bind_space_offsets(vertices: np.ndarray, skeleton: Skeleton, influences: Influences,
                       animation: JointAnimation, refined: np.ndarray, frames: np.ndarray | None = None) -> np.ndarray:
    """(T, V, 3) float32 morph offsets.

    vertices:  (V, 3) float bind-pose positions.
    refined:   (T, V, 3) float world positions at animation frames 0..T-1 (T ≤ animation frames), or at
               `frames` (T,) when given.
    """
    refined = np.asarray(refined, dtype=np.float64)
    v = len(vertices)
    frames = np.arange(len(refined)) if frames is None else np.asarray(frames, np.int64)
    if len(frames) != len(refined) or (len(frames) and not 0 <= frames.min() <= frames.max() < animation.num_frames):
        raise InvalidInput(f"{len(refined)} refined frames do not match their frame numbers {len(frames)} within the "
                           f"animation's {animation.num_frames} frames", code="export_shape_mismatch",
                           field="refined_frames")
    if refined.ndim != 3 or refined.shape[1:] != (v, 3) or not 1 <= len(refined) <= animation.num_frames:
        raise InvalidInput(
            f"refined frames {refined.shape} do not match {v} vertices and {animation.num_frames} animation frames",
            code="export_shape_mismatch", field="refined_frames")
    if not np.all(np.isfinite(refined)):
        raise InvalidInput("refined frames contain non-finite positions", code="export_shape_mismatch",
                           field="refined_frames")
    mats = joint_tracks(skeleton, animation).skin_matrices(skeleton)[frames, :, :3, :]  # (T, J, 3, 4)
    w = influences.weights.astype(np.float64)
    out = np.empty(refined.shape, np.float32)
    for t in range(len(refined)):
        blended = np.einsum("vk,vkab->vab", w, mats[t][influences.joints])  # (V, 3, 4)
        a, b = blended[:, :, :3], blended[:, :, 3]
        rhs = refined[t] - b
        ok = np.abs(np.linalg.det(a)) > SINGULAR_DET
        local = np.empty((v, 3))
        local[ok] = np.linalg.solve(a[ok], rhs[ok][:, :, None])[:, :, 0]
        if not np.all(ok):
            local[~ok] = np.einsum("vab,vb->va", np.linalg.pinv(a[~ok]), rhs[~ok])
        out[t] = local - vertices
    return out
