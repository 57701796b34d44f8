"""The joint tree over free bones: pivots where a pair turns about a point, the border where it slides."""

import numpy as np

from simcore.motion_rig.hierarchy import bone_tree
from simcore.motion_rig.joints import BonePairs


def test_a_sliding_joint_sits_at_the_border_not_at_a_far_best_point():
    rest = np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0, 0]])
    weights = np.eye(3)  # one bone per vertex, a chain 0 - 1 - 2
    pairs = BonePairs(pairs=np.array([[0, 1], [1, 2]]),
                      pivots=np.array([[0.5, 0, 0], [1.5, 9.0, 0]]),  # pair (1, 2) turns about no point near it
                      mismatch=np.array([0.0, 0.5]), overlap=np.ones(2),
                      borders=np.array([[0.5, 0, 0], [1.5, 0, 0]]), stiffness=np.tile(np.eye(3), (2, 1, 1)))
    tree = bone_tree(rest, weights, pairs, slide=0.1)
    assert tree.order[0] == 1  # the centre of the chain is the root
    end = int(np.flatnonzero(tree.order == 2)[0])
    near = int(np.flatnonzero(tree.order == 0)[0])
    assert tree.sliding[end] and tree.floating[end] and not tree.sliding[near]
    assert np.allclose(tree.joints[end], [1.5, 0, 0])
    assert np.allclose(tree.joints[near], [0.5, 0, 0])
