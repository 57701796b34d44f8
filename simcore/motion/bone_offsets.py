"""Animated bone offsets a retarget carries over: where a clip moves a joint away from where its rigid bone
would hold it (a head that pops off, an IK foot that slides under a floor root, a second character's root).

A target bone is the source's bone when its joint and its parent map to a source joint and that joint's parent
(or both are roots): the target joint then moves off its rigid place by what the source joint does, in world
space, scaled as the root motion is. Other target bones stay rigid: their parent follows another source joint,
so the source's offset is measured from somewhere else.
"""

from __future__ import annotations

import numpy as np

from simcore.skeleton.types import Skeleton

MOVES = 1e-6  # × the source's size: a smaller offset from the rigid bone is rounding, not animation


def bone_offsets(source: Skeleton, rest_s: np.ndarray, pos_s: np.ndarray, delta_s: np.ndarray, target: Skeleton,
                 mapping: dict[int, int], scale: float) -> np.ndarray:
    """(T, Jt, 3) world offset of each target joint from its rigid place (zeros where none is carried).

    rest_s (Js, 3), pos_s (T, Js, 3): source rest and per-frame world positions; delta_s (T, Js, 3, 3): source
    world delta rotations (all in the frame the target faces); mapping: target joint → source joint.
    """
    parents_s = source.parents
    ps = np.maximum(parents_s, 0)
    rigid = pos_s[:, ps] + np.einsum("tsab,sb->tsa", delta_s[:, ps], rest_s - rest_s[ps])
    offset = np.where((parents_s < 0)[None, :, None], pos_s - rest_s[None], pos_s - rigid)  # (T, Js, 3)
    size = float(np.ptp(rest_s, axis=0).max()) or 1.0
    moving = np.linalg.norm(offset, axis=2).max(axis=0) > MOVES * size
    out = np.zeros((pos_s.shape[0], target.num_joints, 3))
    for j, s in mapping.items():
        p = int(target.parents[j])
        same_bone = (p < 0 and parents_s[s] < 0) or (p >= 0 and mapping.get(p) == parents_s[s] >= 0)
        if moving[s] and same_bone:
            out[:, j] = scale * offset[:, s]
    return out
