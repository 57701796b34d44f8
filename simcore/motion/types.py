"""Joint animation: per-frame local transforms of a skeleton, the motion stage's output."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


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
