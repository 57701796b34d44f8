"""The batched joint motions match one weighted rigid fit per frame and joint."""

from __future__ import annotations

import numpy as np

from simcore.geometry.similarity import rigid_fit
from simcore.mpm.anchors import joint_motions


def test_joint_motions_match_a_rigid_fit_per_joint() -> None:
    rng = np.random.default_rng(3)
    targets = rng.normal(size=(5, 60, 3)) + [10.0, -4.0, 2.0]  # off the origin, as posed meshes are
    weights = rng.uniform(0.0, 1.0, size=(60, 4))
    weights[:, 2] = 0.0  # a joint with no weight keeps the identity
    weights[:40, 3] = 0.0
    rot, trans = joint_motions(targets, weights)
    assert rot.shape == (5, 4, 3, 3) and trans.shape == (5, 4, 3)
    assert np.array_equal(rot[0], np.tile(np.eye(3), (4, 1, 1))) and np.array_equal(trans[0], np.zeros((4, 3)))
    for t in range(1, 5):
        for m in range(4):
            want_rot, want_trans = rigid_fit(targets[0], targets[t], weights[:, m])
            np.testing.assert_allclose(rot[t, m], want_rot, atol=1e-9, rtol=0)
            np.testing.assert_allclose(trans[t, m], want_trans, atol=1e-9, rtol=0)
    assert np.array_equal(rot[1:, 2], np.tile(np.eye(3), (4, 1, 1))) and not trans[:, 2].any()


def test_joint_motions_of_a_single_frame_are_the_identity() -> None:
    rot, trans = joint_motions(np.ones((1, 3, 3)), np.ones((3, 2)))
    assert np.array_equal(rot, np.tile(np.eye(3), (1, 2, 1, 1))) and not trans.any()
