"""Per-frame rigid bone transforms on a joint tree → local joint animation (glTF-style TRS)."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from simcore.motion.types import JointAnimation
from simcore.skeleton.types import Skeleton


def joint_animation(skeleton: Skeleton, transforms: np.ndarray, fps: float, name: str = "clip") -> JointAnimation:
    """Local rotations and translations of `skeleton`'s joints (world-aligned at rest) from skinning transforms.

    transforms: (T, J, 4, 4) rigid maps from rest to frame t, joint order of `skeleton` (parents first).
    """
    rot, trans = transforms[:, :, :3, :3], transforms[:, :, :3, 3]
    heads = np.einsum("tjab,jb->tja", rot, skeleton.positions) + trans  # joint positions per frame
    local_rot = rot.copy()
    local_trans = heads.copy()
    for j, p in enumerate(skeleton.parents.tolist()):
        if p >= 0:
            inv = np.swapaxes(rot[:, p], -1, -2)
            local_rot[:, j] = inv @ rot[:, j]
            local_trans[:, j] = np.einsum("tab,tb->ta", inv, heads[:, j] - heads[:, p])
    steps, count = rot.shape[:2]
    quats = Rotation.from_matrix(local_rot.reshape(-1, 3, 3)).as_quat().reshape(steps, count, 4)
    for t in range(1, steps):  # the shorter way round between frames: no flips when interpolated
        flip = (quats[t] * quats[t - 1]).sum(-1) < 0
        quats[t, flip] *= -1
    return JointAnimation(list(skeleton.names), float(fps), quats, local_trans, name=name)
