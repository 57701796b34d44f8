"""A leaf joint's segment points into the mesh part nearest to it (bones.leaf_tails), not along its parent bone."""

from __future__ import annotations

import numpy as np

from simcore.skeleton.types import Skeleton
from simcore.skinning.bones import joint_segments


def _kenney_like() -> tuple[Skeleton, np.ndarray]:
    """An unweighted root (a helper, as a job keeping the rig reads it) at the feet with a leg and a torso hung
    from it (the leg's parent bone points up), an arm off the torso held out sideways; points along the leg below
    its joint and along the arm beyond its joint."""
    rig = Skeleton(np.array([[0.0, 0.0, 0.0], [0.1, 0.5, 0.0], [0.0, 0.5, 0.0], [0.15, 0.8, 0.0]]),
                   np.array([-1, 0, 0, 2]), ["root", "leg", "torso", "arm"]).with_helpers(np.arange(4) == 0)
    leg = np.column_stack([np.full(40, 0.1), np.linspace(0.0, 0.45, 40), np.zeros(40)])
    arm = np.column_stack([np.linspace(0.2, 0.7, 40), np.full(40, 0.8), np.zeros(40)])
    return rig, np.vstack([leg, arm])


def _leaf_offset(segments, joint: int) -> np.ndarray:
    s = int(np.flatnonzero((segments.owner == joint) & segments.leaf)[0])
    return segments.tails[s] - segments.heads[s]


def test_a_leaf_hung_from_a_distant_parent_points_into_its_part():
    rig, points = _kenney_like()
    old, new = joint_segments(rig, 1.0), joint_segments(rig, 1.0, points)
    assert _leaf_offset(old, 1)[1] > 0.0  # the parent bone continued: up into the body
    leg = _leaf_offset(new, 1)
    assert leg[1] < -0.3 and abs(leg[0]) < 0.05  # down the leg, near its far end
    arm = _leaf_offset(new, 3)
    assert arm[0] > 0.4 and abs(arm[1]) < 0.05  # out along the arm, not up the torso's line
    assert np.allclose(new.heads, old.heads) and np.array_equal(new.owner, old.owner)
    np.testing.assert_allclose(new.tails[~new.leaf], old.tails[~old.leaf])  # bones to children stay


def test_a_leaf_no_point_lies_nearest_keeps_the_parent_bone_continued():
    rig, points = _kenney_like()
    new = joint_segments(rig, 1.0, points[:40])  # the leg alone: nothing lies nearest to the arm
    np.testing.assert_allclose(_leaf_offset(new, 3), _leaf_offset(joint_segments(rig, 1.0), 3))


def test_a_leaf_whose_part_lies_all_around_it_keeps_the_parent_bone_continued():
    """A tube's end cap: the points nearest the tip joint ring it, leaning no way."""
    rig = Skeleton(np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 2.0, 0.0]]), np.array([-1, 0, 1]),
                   ["a", "b", "c"])
    angles = np.linspace(0.0, 2.0 * np.pi, 12, endpoint=False)
    ring = np.column_stack([0.1 * np.cos(angles), np.zeros(12), 0.1 * np.sin(angles)])
    points = np.vstack([ring + [0.0, y, 0.0] for y in (0.0, 0.5, 1.0, 1.5, 2.0)])
    np.testing.assert_allclose(_leaf_offset(joint_segments(rig, 1.0, points), 2), [0.0, 1.0, 0.0])
