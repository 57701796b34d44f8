"""A JointAnimation laid out on a Skeleton's joint order, ready for the glTF and USD writers."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from simcore.errors import InvalidInput
from simcore.motion.types import JointAnimation
from simcore.skeleton.kinematics import compose, global_transforms, rest_local_matrices, skinning_matrices
from simcore.skeleton.types import Skeleton


@dataclass
class JointTracks:
    """Per-frame local transforms in skeleton joint order.

    rotations:    (T, J, 4) float64 unit quaternions xyzw, sign-continuous over time per joint.
    translations: (T, J, 3) float64 metres.
    animated:     (J,) bool, joints the clip names (others hold their rest transform).
    times:        (T,) float64 seconds, k / fps.
    """

    rotations: np.ndarray
    translations: np.ndarray
    animated: np.ndarray
    times: np.ndarray

    def skin_matrices(self, skeleton: Skeleton) -> np.ndarray:
        """(T, J, 4, 4) world(pose) @ inverse(world(bind)) per frame, for LBS."""
        world = global_transforms(skeleton, compose(self.rotations, self.translations))
        return skinning_matrices(skeleton, world)


def continuous_quaternions(quats: np.ndarray) -> np.ndarray:
    """(T, ..., 4) unit quaternions with each one on the same hemisphere as the previous frame's."""
    q = quats / np.linalg.norm(quats, axis=-1, keepdims=True)
    if len(q) < 2:
        return q
    step = np.sign(np.sum(q[1:] * q[:-1], axis=-1))
    step[step == 0] = 1.0
    flips = np.concatenate([np.ones_like(step[:1]), np.cumprod(step, axis=0)])
    return q * flips[..., None]


def joint_tracks(skeleton: Skeleton, animation: JointAnimation) -> JointTracks:
    """Map the clip's joints onto `skeleton` by name; unknown clip joints are an error, missing ones rest."""
    t = animation.num_frames
    rot = np.asarray(animation.rotations, dtype=np.float64)
    trans = np.asarray(animation.translations, dtype=np.float64)
    n = len(animation.joint_names)
    if t < 1 or rot.shape != (t, n, 4) or trans.shape != (t, n, 3):
        raise InvalidInput(f"animation arrays {rot.shape}/{trans.shape} disagree with {n} joints",
                           code="export_shape_mismatch", field="animation")
    if not (np.all(np.isfinite(rot)) and np.all(np.isfinite(trans))) or not animation.fps > 0:
        raise InvalidInput("animation has non-finite values or fps", code="export_shape_mismatch", field="animation")
    slot = {name: j for j, name in enumerate(skeleton.names)}
    unknown = [name for name in animation.joint_names if name not in slot]
    if unknown:
        raise InvalidInput(f"animation joints not in the skeleton: {unknown[:5]}", code="export_shape_mismatch",
                           field="animation")
    rest = rest_local_matrices(skeleton)
    out_rot = np.broadcast_to(Rotation.from_matrix(rest[:, :3, :3]).as_quat(), (t, skeleton.num_joints, 4)).copy()
    out_trans = np.broadcast_to(rest[:, :3, 3], (t, skeleton.num_joints, 3)).copy()
    idx = np.asarray([slot[name] for name in animation.joint_names], dtype=np.int64)
    out_rot[:, idx] = rot
    out_trans[:, idx] = trans
    animated = np.zeros(skeleton.num_joints, bool)
    animated[idx] = True
    return JointTracks(continuous_quaternions(out_rot), out_trans, animated, np.arange(t) / float(animation.fps))
