"""Joint animation: per-frame local transforms of a skeleton, the motion stage's output."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import scipy.sparse as sp

    from simcore.skeleton.types import Skeleton


@dataclass
class JointAnimation:
    """Per-frame local joint transforms for one target Skeleton.

    joint_names:  J names, in the target Skeleton's joint order.
    fps:          frames per second (uniform sampling; frame k is at time k / fps seconds).
    rotations:    (T, J, 4) float64 local rotation quaternions, xyzw (glTF order), in the parent joint's
                  frame. For a skeleton without `orientations` the rest value is identity.
    translations: (T, J, 3) float64 local translations in metres (rest value: child - parent rest position,
                  the root's rest value is its rest world position).
    name:         clip name.
    loop:         whether the clip is meant to loop.
    """

    joint_names: list[str]
    fps: float
    rotations: np.ndarray
    translations: np.ndarray
    name: str = "clip"
    loop: bool = False

    @property
    def num_frames(self) -> int:
        return int(self.rotations.shape[0])

    @property
    def duration(self) -> float:
        return (self.num_frames - 1) / self.fps if self.num_frames > 1 else 0.0


@dataclass
class MotionClip:
    """A source motion before retargeting: its own skeleton and that skeleton's local animation.

    skeleton:  the source skeleton at rest (metres, +Y up); `orientations` set when joint frames are not
               world-aligned at rest (glTF bind poses), None for BVH (rest local rotation = identity).
    animation: JointAnimation in `skeleton`'s joint order.
    rest_is_standing: True when the rest pose stands on the floor at the clip's origin (glTF bind poses),
               so the rest pose anchors root motion and ground height; False for BVH, whose rest pose
               floats at the origin (the first frame and the clip's lowest foot are used instead).
    source_format: "bvh", "gltf", ... for the report.
    unit_scale: factor applied to the file's units to get metres.
    unit:      how unit_scale was chosen: a guessed unit name ("cm", "in", ...), "option" or "file".
    shares_bind_pose: True when the rest pose is the bind pose of the very mesh being rigged, in that mesh's
               frame (a clip carried by the mesh upload): the target skeleton was built on the same body in the
               same pose, so where its bones point differently from the source's, they are placed differently,
               not posed differently, and the retarget neither turns them at rest nor rescales root motion.
    bind_weights: (V, Js) the mesh's own skin weights over this clip's joints, rows in the rigged mesh's vertex
               order, when the clip is that mesh's own and its skin was read: which source joint moves which
               flesh (the retarget maps joints that move the same flesh; `body_map.flesh_shares`).
    """

    skeleton: Skeleton
    animation: JointAnimation
    rest_is_standing: bool = False
    source_format: str = "bvh"
    unit_scale: float = 1.0
    unit: str = "file"
    shares_bind_pose: bool = False
    bind_weights: sp.csr_matrix | None = None
