"""Move a MotionClip into another frame (similarity transform), e.g. the ingested mesh's frame."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from simcore.motion.types import JointAnimation, MotionClip
from simcore.skeleton.types import Skeleton


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
