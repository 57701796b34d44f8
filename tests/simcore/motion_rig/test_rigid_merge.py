"""Touching free bones with one motion merge into one bone; bones that move apart stay."""

import numpy as np
from scipy.spatial.transform import Rotation

from simcore.motion_rig.free_bones import BoneFit
from simcore.motion_rig.rigid_merge import merge_moving_alike


def _strip(count: int) -> tuple[np.ndarray, np.ndarray]:
    """A strip of `count` unit squares along x (two triangles each)."""
    xs = np.arange(count + 1, dtype=np.float64)
    rest = np.concatenate([np.stack([xs, np.zeros_like(xs), np.zeros_like(xs)], 1),
                           np.stack([xs, np.ones_like(xs), np.zeros_like(xs)], 1)])
    n = count + 1
    faces = [[i, i + 1, n + i] for i in range(count)] + [[i + 1, n + i + 1, n + i] for i in range(count)]
    return rest, np.asarray(faces, np.int64)


def test_bones_moving_alike_merge_and_the_others_stay():
    rest, faces = _strip(3)
    owner = np.minimum(rest[:, 0].astype(int), 2)  # bone 0: x 0..1, bone 1: x 1..2 (x=2 column), bone 2: x 3
    weights = np.eye(3)[owner]
    steps = 5
    turn = Rotation.from_euler("z", np.linspace(0, 0.8, steps)[:, None]).as_matrix()
    transforms = np.tile(np.eye(4), (steps, 3, 1, 1))
    transforms[:, 0, :3, :3] = transforms[:, 1, :3, :3] = turn  # bones 0 and 1 move as one
    transforms[:, 1, :3, 3] = 1e-6  # within the tolerance
    transforms[:, 2, :3, 3] = np.linspace(0, 0.5, steps)[:, None]  # bone 2 slides away
    merged, gone = merge_moving_alike(rest, faces, BoneFit(weights, transforms), tolerance=1e-3)
    assert gone == 1 and merged.num_bones == 2
    assert np.allclose(merged.weights.sum(axis=1), 1.0)
    groups = {tuple(np.flatnonzero(merged.weights[:, g] > 0)) for g in range(2)}
    assert tuple(np.flatnonzero(owner < 2)) in groups and tuple(np.flatnonzero(owner == 2)) in groups
    same, none = merge_moving_alike(rest, faces, BoneFit(weights, transforms), tolerance=1e-9)
    assert none == 0 and same.num_bones == 3
