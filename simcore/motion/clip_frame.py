"""Move a MotionClip into another frame (similarity transform), e.g. the ingested mesh's frame."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from simcore.motion.types import JointAnimation, MotionClip
from simcore.skeleton.types import Skeleton


def similarity_fit(source: np.ndarray, target: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """(s, R (3, 3), t (3,)) minimising Σ|s R source_i + t - target_i|² (Umeyama); source, target (N, 3)."""
    mu_s, mu_t = source.mean(0), target.mean(0)
    a, b = source - mu_s, target - mu_t
    u, sig, vt = np.linalg.svd(b.T @ a / len(a))
    d = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt)) or 1.0])
    rot = u @ d @ vt
    var = float((a ** 2).sum() / len(a))
    scale = float(np.trace(np.diag(sig) @ d) / var) if var > 0 else 1.0
    return scale, rot, mu_t - scale * rot @ mu_s


def transform_clip(clip: MotionClip, scale: float, rotation: np.ndarray, translation: np.ndarray) -> MotionClip:
    """The clip seen through x → scale · rotation · x + translation (rotation (3, 3), translation (3,))."""
    skel = clip.skeleton
    rot = Rotation.from_matrix(rotation)
    orient = None if skel.orientations is None else (rot * Rotation.from_quat(skel.orientations)).as_quat()
    positions = scale * skel.positions @ rotation.T + translation
    moved = Skeleton(positions, skel.parents, skel.names, skel.kinds, orient)
    anim = clip.animation
    rotations = anim.rotations.copy()
    translations = anim.translations * scale
    roots = np.flatnonzero(skel.parents < 0)
    t = anim.num_frames
    # Only roots see the new frame; children are parent-relative, so only the length scale reaches them.
    root_rot = rot * Rotation.from_quat(anim.rotations[:, roots].reshape(-1, 4))
    rotations[:, roots] = root_rot.as_quat().reshape(t, len(roots), 4)
    translations[:, roots] = anim.translations[:, roots] * scale @ rotation.T + translation
    new_anim = JointAnimation(list(anim.joint_names), anim.fps, rotations, translations, anim.name, anim.loop)
    return MotionClip(moved, new_anim, clip.rest_is_standing, clip.source_format, clip.unit_scale * scale, clip.unit,
                      clip.shares_bind_pose)
