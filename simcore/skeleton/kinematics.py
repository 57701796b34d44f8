"""Forward kinematics for Skeleton poses (column vectors, 4x4 homogeneous matrices, quaternions xyzw)."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from simcore.skeleton.types import Skeleton, parents_first_order


def bind_matrices(skeleton: Skeleton) -> np.ndarray:
    """(J, 4, 4) float64 world transform of each joint frame at bind (rotation from `orientations`)."""
    out = np.tile(np.eye(4), (skeleton.num_joints, 1, 1))
    if skeleton.orientations is not None:
        out[:, :3, :3] = Rotation.from_quat(skeleton.orientations).as_matrix()
    out[:, :3, 3] = skeleton.positions
    return out


def rest_local_matrices(skeleton: Skeleton) -> np.ndarray:
    """(J, 4, 4) float64 local (parent-relative) transform of each joint at bind."""
    bind = bind_matrices(skeleton)
    parent = np.where(skeleton.parents[:, None, None] >= 0, bind[np.maximum(skeleton.parents, 0)], np.eye(4))
    return np.linalg.inv(parent) @ bind


def compose(rotations: np.ndarray, translations: np.ndarray) -> np.ndarray:
    """(..., 4, 4) from rotations (..., 4) xyzw and translations (..., 3)."""
    shape = rotations.shape[:-1]
    out = np.zeros(shape + (4, 4))
    out[..., :3, :3] = Rotation.from_quat(rotations.reshape(-1, 4)).as_matrix().reshape(shape + (3, 3))
    out[..., :3, 3] = translations
    out[..., 3, 3] = 1.0
    return out


def global_transforms(skeleton: Skeleton, local: np.ndarray) -> np.ndarray:
    """(..., J, 4, 4) world joint transforms from local ones (..., J, 4, 4); joints in any order, any roots."""
    out = np.array(local, copy=True)  # roots keep their local; every other joint is set below
    for j in parents_first_order(skeleton.parents):
        p = skeleton.parents[j]
        if p >= 0:
            out[..., j, :, :] = out[..., p, :, :] @ local[..., j, :, :]
    return out


def skinning_matrices(skeleton: Skeleton, world: np.ndarray) -> np.ndarray:
    """(..., J, 4, 4) world(pose) @ inverse(world(bind)): what LBS applies to bind-pose vertices."""
    return world @ np.linalg.inv(bind_matrices(skeleton))


def random_pose_locals(skeleton: Skeleton, rng: np.random.Generator, max_degrees: float = 45.0) -> np.ndarray:
    """(J, 4, 4) local transforms for the deformation protocol: each joint rotates about its bind position by
    a rotation vector with components uniform in ±max_degrees/√3; rest local translations kept."""
    rest = rest_local_matrices(skeleton)
    rot = Rotation.from_rotvec(rng.uniform(-1, 1, (skeleton.num_joints, 3)) * np.deg2rad(max_degrees) / np.sqrt(3))
    out = rest.copy()
    out[:, :3, :3] = rest[:, :3, :3] @ rot.as_matrix()
    return out
