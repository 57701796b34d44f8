"""Shape joints: where the motion shows no bend, joints come from the mesh's shape and change no frame."""

import numpy as np
import pytest

from simcore.evaluation.motion_sequences import tube_sequence
from simcore.geometry.voxelize import solid_voxels
from simcore.motion_rig.free_bones import reconstruct
from simcore.motion_rig.shape_joints import _split_weights, add_shape_joints
from simcore.skeleton.types import Skeleton


@pytest.fixture(scope="module")
def tube():
    return tube_sequence(24, 12, 3, 6, seed=1)


def _rigid_rig(tube):
    """A two-bone motion rig of the tube: the far half turns as one piece about the middle, the near half is still."""
    far = tube.rest[:, 0] > 0.5
    weights = np.stack([~far, far], axis=1).astype(np.float64)
    transforms = np.tile(np.eye(4), (4, 2, 1, 1))
    for t in range(4):
        c, s = np.cos(0.2 * t), np.sin(0.2 * t)
        transforms[t, 1, :3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
        transforms[t, 1, :3, 3] = np.array([0.5, 0, 0]) - transforms[t, 1, :3, :3] @ [0.5, 0, 0]
    skeleton = Skeleton(np.array([[0.25, 0, 0], [0.5, 0, 0]]), np.array([-1, 0]), ["root", "bone_01"])
    return skeleton, weights, transforms


def test_shape_joints_fill_the_parts_that_never_bend_without_changing_the_fit(tube):
    skeleton, weights, transforms = _rigid_rig(tube)
    grid = solid_voxels(tube.rest, tube.faces, resolution=48)
    grown = add_shape_joints(tube.rest, tube.faces, skeleton, weights, transforms, grid, reach=1.0, max_joints=64,
                             max_influences=4)
    added = len(grown.owner)
    assert added >= 2  # a 1 m tube 0.12 m thick has room for joints between and beyond the two motion joints
    assert grown.skeleton.num_joints == 2 + added
    assert np.allclose(grown.skeleton.positions[:2], skeleton.positions)
    gaps = np.linalg.norm(grown.skeleton.positions[2:, None] - skeleton.positions[None], axis=-1).min(axis=1)
    assert (gaps > 0.06 - grid.pitch).all()  # at least about one thickness from every motion joint
    assert np.allclose(grown.weights.sum(axis=1), 1.0)
    assert (np.count_nonzero(grown.weights, axis=1) <= 4).all()
    assert np.allclose(grown.transforms[:, 2:], transforms[:, grown.owner])
    before = reconstruct(tube.rest, weights, transforms)
    assert np.abs(reconstruct(tube.rest, grown.weights, grown.transforms) - before).max() < 1e-9
    moved = grown.weights[:, 2:].sum(axis=0)
    assert (moved > 0).all()  # every added joint carries some of its bone's vertices


def test_no_room_adds_nothing(tube):
    skeleton, weights, transforms = _rigid_rig(tube)
    grid = solid_voxels(tube.rest, tube.faces, resolution=48)
    grown = add_shape_joints(tube.rest, tube.faces, skeleton, weights, transforms, grid, reach=1.0, max_joints=2,
                             max_influences=4)
    assert grown.skeleton is skeleton and len(grown.owner) == 0


def test_split_keeps_each_groups_weight_and_the_influence_cap():
    weights = np.array([[0.5, 0.3, 0.2], [1.0, 0.0, 0.0], [0.0, 0.6, 0.4]])
    group = np.array([0, 1, 2, 0, 0, 1])  # joints 3, 4 move with bone 0, joint 5 with bone 1
    shares = np.array([[0.1, 0.2, 0.1, 0.3, 0.2, 0.1], [0.0, 0.5, 0.0, 0.0, 0.0, 0.5], [0.2, 0.2, 0.2, 0.2, 0.0, 0.2]])
    split = _split_weights(weights, shares, group, max_influences=4)
    members = np.zeros((3, 6))
    members[group, np.arange(6)] = 1.0
    assert np.allclose(split @ members.T, weights)  # the skinned mesh is the same
    assert (np.count_nonzero(split, axis=1) <= 4).all()
    assert split[1, 0] == 1.0  # no share of bone 0's group reaches vertex 1: bone 0 keeps it
    assert split[0, 3] > split[0, 0]  # the best member of a group keeps a slot
