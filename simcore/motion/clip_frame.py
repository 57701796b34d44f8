"""Move a MotionClip into another frame (similarity transform), e.g. the ingested mesh's frame."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.spatial.transform import Rotation

from simcore.geometry.similarity import similarity_fit
from simcore.motion.types import JointAnimation, MotionClip
from simcore.skeleton.types import Skeleton

AXIS_REACH = 0.2  # × the heads' reach from their centroid: how far along each joint frame's axes the fit's extra points lie


def _frame_points(heads: np.ndarray, orientations: np.ndarray | None) -> np.ndarray:
    """The joints' `heads` (J, 3), plus (with `orientations`, (J, 4) xyzw) a point along each axis of every joint
    frame, AXIS_REACH of the heads' reach from their centroid away (a length a similarity scales with the skeleton):
    points that fix a rotation even when the heads lie on one line."""
    if orientations is None:
        return heads
    span = float(np.linalg.norm(heads - heads.mean(axis=0), axis=1).max()) or 1.0
    axes = Rotation.from_quat(orientations).as_matrix()  # (J, 3, 3): columns are the frame's axes
    return np.vstack([heads, *(heads + AXIS_REACH * span * axes[:, :, k] for k in range(3))])


def skeleton_similarity(source: Skeleton, target: Skeleton, order: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """(s, R, t) taking `source`'s bind pose onto `target`'s, where source joint i is target joint order[i]:
    fitted to the heads and, when both skeletons carry their joint frames, to points along those frames' axes.
    Heads alone leave a rotation about their line free (a two-bone rig), which could turn a clip's bends the
    other way."""
    if source.orientations is None or target.orientations is None:
        return similarity_fit(source.positions, target.positions[order])
    return similarity_fit(_frame_points(source.positions, source.orientations),
                          _frame_points(target.positions[order], target.orientations[order]))


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
    return replace(clip, skeleton=moved, animation=new_anim, unit_scale=clip.unit_scale * scale)
