"""The batched joint motions recover each joint's known rigid motion; a joint without weight keeps the identity."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from simcore.mpm.anchors import joint_motions


def test_joint_motions_recover_each_joints_rigid_motion() -> None:
    """Joint m weighs only its own 15 vertices, which move rigidly by a known R, t in every frame: the weighted
    fit must return exactly that motion, whatever the weights' values."""
    rng = np.random.default_rng(3)
    rest = rng.normal(size=(60, 3)) + [10.0, -4.0, 2.0]  # off the origin, as posed meshes are
    weights = np.zeros((60, 4))
    for m in (0, 1, 3):
        weights[15 * m:15 * m + 15, m] = rng.uniform(0.1, 1.0, 15)  # joint 2 has no weight: it keeps the identity
    rots = Rotation.random(5 * 4, random_state=4).as_matrix().reshape(5, 4, 3, 3)
    shifts = rng.normal(size=(5, 4, 3))
    rots[0], shifts[0] = np.eye(3), 0.0
    owner = np.repeat(np.arange(4), 15)
    targets = np.einsum("tvab,vb->tva", rots[:, owner], rest) + shifts[:, owner]
    rot, trans = joint_motions(targets, weights)
    assert rot.shape == (5, 4, 3, 3) and trans.shape == (5, 4, 3)
    assert np.array_equal(rot[0], np.tile(np.eye(3), (4, 1, 1))) and np.array_equal(trans[0], np.zeros((4, 3)))
    for m in (0, 1, 3):
        np.testing.assert_allclose(rot[1:, m], rots[1:, m], atol=1e-9, rtol=0)
        np.testing.assert_allclose(trans[1:, m], shifts[1:, m], atol=1e-9, rtol=0)
    assert np.array_equal(rot[1:, 2], np.tile(np.eye(3), (4, 1, 1))) and not trans[:, 2].any()


def test_joint_motions_of_a_single_frame_are_the_identity() -> None:
    rot, trans = joint_motions(np.ones((1, 3, 3)), np.ones((3, 2)))
    assert np.array_equal(rot, np.tile(np.eye(3), (1, 2, 1, 1))) and not trans.any()
