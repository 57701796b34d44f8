"""Skeleton.without: the tree of the kept joints, each hung from its nearest kept ancestor."""

from __future__ import annotations

import numpy as np
import pytest

from simcore.errors import InvalidInput
from simcore.skeleton.types import Skeleton


def test_a_dropped_middle_joint_hands_its_children_to_its_parent() -> None:
    # root → spine → neck → head, and root → ik (a control hanging from the root)
    skeleton = Skeleton(np.arange(15.0).reshape(5, 3), np.array([-1, 0, 1, 2, 0]), ["root", "spine", "neck", "head", "ik"])
    sub, kept = skeleton.without(np.array([False, False, True, False, True]))
    assert kept.tolist() == [0, 1, 3]
    assert sub.names == ["root", "spine", "head"] and sub.parents.tolist() == [-1, 0, 1]
    np.testing.assert_array_equal(sub.positions, skeleton.positions[[0, 1, 3]])
    sub.validate()


def test_the_root_stays() -> None:
    skeleton = Skeleton(np.zeros((2, 3)), np.array([-1, 0]), ["root", "tip"])
    with pytest.raises(InvalidInput):
        skeleton.without(np.array([True, False]))
