"""Forward kinematics and the deformation protocol hold for joints in any order and for several roots."""

from __future__ import annotations

import numpy as np
import pytest

from simcore.errors import InvalidInput
from simcore.metrics.skinning import POSES, SEED, protocol_skin_matrices
from simcore.skeleton.kinematics import compose, global_transforms, random_pose_locals, skinning_matrices
from simcore.skeleton.types import Skeleton, parents_first_order


def _chain() -> Skeleton:
    """A 4-joint chain up +Y plus a separate prop root, listed children first."""
    #   slot:        0: elbow  1: prop  2: hand  3: root  4: shoulder
    positions = [[0, 2, 0], [1, 0, 0], [0, 3, 0], [0, 0, 0], [0, 1, 0]]
    return Skeleton(np.array(positions, float), np.array([4, -1, 0, -1, 3]), ["elbow", "prop", "hand", "root", "shoulder"])


def test_parents_first_order_puts_every_parent_before_its_children():
    order = parents_first_order(_chain().parents)
    rank = np.empty(5, int)
    rank[order] = np.arange(5)
    parents = _chain().parents
    assert sorted(order.tolist()) == list(range(5))
    assert all(parents[j] < 0 or rank[parents[j]] < rank[j] for j in range(5))


def test_parents_first_order_refuses_a_cycle():
    with pytest.raises(InvalidInput, match="cycle"):
        parents_first_order(np.array([-1, 2, 1]))


def test_global_transforms_match_the_parents_first_layout():
    skeleton = _chain()
    rng = np.random.default_rng(3)
    quats = rng.normal(size=(2, 5, 4))
    local = compose(quats / np.linalg.norm(quats, axis=-1, keepdims=True), rng.normal(size=(2, 5, 3)))
    order = parents_first_order(skeleton.parents)
    expected = global_transforms(skeleton.reordered(order), local[:, order])
    got = global_transforms(skeleton, local)
    np.testing.assert_allclose(got[:, order], expected, atol=1e-12)
    assert np.isfinite(got).all()


def test_random_pose_protocol_poses_each_joint_under_its_parent():
    skeleton = _chain()
    order = parents_first_order(skeleton.parents)
    ordered = skeleton.reordered(order)
    rng = np.random.default_rng(SEED)  # the protocol's own draws, joint by joint in the skeleton's order
    local = np.stack([random_pose_locals(skeleton, rng) for _ in range(POSES)])
    expected = skinning_matrices(ordered, global_transforms(ordered, local[:, order]))
    np.testing.assert_allclose(protocol_skin_matrices(skeleton)[:, order], expected, atol=1e-12)


def test_parents_first_order_keeps_an_ordered_skeleton_as_it_is():
    assert parents_first_order(np.array([-1, 0, 1, 0, 3, -1])).tolist() == [0, 1, 2, 3, 4, 5]
