"""Medial-path helpers: where a limb leaves the body, and the joint the geometric method puts there."""

from __future__ import annotations

import numpy as np
import pytest

from simcore.skeleton.geometric import GeometricParams, _with_limb_root
from simcore.skeleton.graph_simplify import limb_exit


def test_limb_exit_is_where_the_medial_radius_falls_to_the_limbs_own():
    chest, arm = [0.10, 0.09, 0.07, 0.04], [0.03] * 8
    assert limb_exit(np.array(chest + arm), 1.5) == 3  # 0.04 <= 1.5 × 0.03 (the median over the middle half)
    assert limb_exit(np.array(chest + arm), 2.5) == 2  # 0.07 <= 2.5 × 0.03
    assert limb_exit(np.array([0.03] * 10), 1.5) == 0  # no body on the path: the limb starts at once


def _limb(reverse: bool = False):
    """A straight limb of 21 medial nodes 0.05 apart off a junction (node 0, degree 3) to a leaf (node 20): the
    body's ball radius 0.3 shrinks to the limb's 0.05 by node 6 (x = 0.3, where the limb leaves the body)."""
    pos = np.zeros((23, 3))
    pos[:21, 0] = 0.05 * np.arange(21)
    pos[21:, 1] = [-0.05, 0.05]  # the junction's two other neighbours
    rad = np.array([0.3, 0.3, 0.25, 0.2, 0.15, 0.1] + [0.05] * 15 + [0.3, 0.3])
    adjacency = [[1, 21, 22]] + [[i - 1, i + 1] for i in range(1, 20)] + [[19], [0], [0]]
    nodes = list(range(21))
    return (nodes[::-1] if reverse else nodes), adjacency, pos, rad


@pytest.mark.parametrize("reverse", [False, True])
def test_a_limb_gets_a_joint_where_it_leaves_the_body(reverse: bool):
    nodes, adjacency, pos, rad = _limb(reverse)
    params = GeometricParams()  # limb_exit 1.5: the first node with radius <= 0.075 is node 6
    exit_index = nodes.index(6)
    assert _with_limb_root(nodes, [], adjacency, pos, rad, params, spacing=0.2) == [exit_index]
    far = nodes.index(15)
    assert _with_limb_root(nodes, [far], adjacency, pos, rad, params, spacing=0.2) == sorted([exit_index, far])


def test_no_limb_root_next_to_a_joint_near_the_tip_or_off_a_limb():
    nodes, adjacency, pos, rad = _limb()
    params = GeometricParams()
    assert _with_limb_root(nodes, [7], adjacency, pos, rad, params, spacing=0.2) == [7]  # a joint 0.05 away
    assert _with_limb_root(nodes, [], adjacency, pos, rad, params, spacing=0.8) == []  # under a spacing left
    near_junction = GeometricParams(limb_gap=2.0)  # the junction itself is within 2 × 0.2 of x = 0.3
    assert _with_limb_root(nodes, [], adjacency, pos, rad, near_junction, spacing=0.2) == []
    chain = [[1]] + [[i - 1, i + 1] for i in range(1, 20)] + [[19], [], []]  # leaf to leaf: no junction, no limb
    assert _with_limb_root(nodes, [], chain, pos, rad, params, spacing=0.2) == []
