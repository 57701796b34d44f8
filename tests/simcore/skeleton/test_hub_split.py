"""Hub splitting: limbs that thinning joins at one point of a short, wide trunk get a junction per pair."""

from __future__ import annotations

import numpy as np

from simcore.geometry.capsule_creatures import quadruped
from simcore.skeleton.geometric import geometric_skeleton
from simcore.skeleton.graph_simplify import Branch
from simcore.skeleton.hub_split import split_hubs
from simcore.skeleton.mirror import MirrorPlane, mirror_plane


def _leg_junction(skeleton, foot: int) -> int:
    """The first joint above `foot` that has more than one child."""
    kids = skeleton.children()
    j = foot
    while skeleton.parents[j] >= 0 and len(kids[skeleton.parents[j]]) < 2:
        j = skeleton.parents[j]
    return int(skeleton.parents[j])


def test_stocky_quadruped_hangs_front_and_back_legs_from_their_own_junctions():
    vertices, faces, _ = quadruped(trunk=0.2, girth=0.24)  # hips and shoulders ±0.2 m, inside a 0.24 m chest
    skeleton, _ = geometric_skeleton(vertices, faces)
    skeleton.validate()
    kids = skeleton.children()
    feet = [j for j in range(skeleton.num_joints) if not kids[j] and skeleton.positions[j, 1] < 0.4]  # not head, tail
    assert len(feet) == 4
    for foot in feet:
        junction = skeleton.positions[_leg_junction(skeleton, foot)]
        built = 0.2 if skeleton.positions[foot, 0] > 0 else -0.2  # thinning alone puts all four at x ≈ 0
        assert abs(junction[0] - built) < 0.06
    assert len({_leg_junction(skeleton, foot) for foot in feet}) == 2


def _x_hub(extra_branch: bool) -> tuple[dict, dict, list[Branch], np.ndarray, np.ndarray]:
    """A medial hub at the origin (radius 1) with two mirror pairs of diagonal limbs along ±x, mirrored in z,
    a spine branch along +x, and optionally a lone branch off the mirror plane."""
    positions, radius, branch_list = [np.zeros(3)], [1.0], []
    ends = [(1, 1), (1, -1), (-1, 1), (-1, -1), (2, 0)] + ([(0.3, 1.5)] if extra_branch else [])
    for dx, dz in ends:
        ids = []
        for k in range(1, 9):
            s = k / 8.0
            positions.append(np.array([dx * 1.5 * s, -2.0 * s * (dz != 0), dz * 1.2 * s]))
            radius.append(1.0 - 0.7 * s)
            ids.append(len(positions) - 1)
        branch_list.append(Branch(0, ids[-1], [0, *ids]))
    keys = [0] + [b.end for b in branch_list]
    return {k: k for k in keys}, {k: positions[k] for k in keys}, branch_list, np.array(positions), np.array(radius)


def test_split_gives_one_junction_per_pair_and_hangs_the_spine_from_the_end_one():
    rep, merged, branch_list, positions, radius = _x_hub(extra_branch=False)
    before = (dict(rep), {k: p.copy() for k, p in merged.items()}, [Branch(b.start, b.end, list(b.nodes)) for b in branch_list])
    split = split_hubs(rep, merged, branch_list, positions, radius, MirrorPlane(2, 0.0), len(positions))
    assert len(split.links) == 1
    back, front = sorted(split.links[0], key=lambda key: split.merged[key][0])
    assert split.merged[back][0] < -0.5 < 0.5 < split.merged[front][0]
    starts = [b.start for b in split.branches]
    assert starts == [front, front, back, back, front]  # legs by side, the spine (+x) from the front junction
    assert all(radius[b.nodes[0]] < 0.6 for b in split.branches[:4])  # limbs start where they leave the trunk
    assert rep == before[0] and branch_list == before[2]  # inputs untouched
    assert merged.keys() == before[1].keys() and all(np.array_equal(merged[k], before[1][k]) for k in merged)


def test_hub_with_a_branch_that_has_no_mirror_partner_is_left_alone():
    rep, merged, branch_list, positions, radius = _x_hub(extra_branch=True)
    split = split_hubs(rep, merged, branch_list, positions, radius, MirrorPlane(2, 0.0), len(positions))
    assert split.links == [] and split.branches == branch_list


def test_mirror_plane_finds_the_axis_a_shape_is_symmetric_across():
    rng = np.random.default_rng(3)
    half = rng.uniform([0.1, -1, -2], [1, 1, 2], size=(200, 3))
    points = np.concatenate([half, half * [-1, 1, 1]]) + [0.5, 0, 0]
    plane = mirror_plane(points)
    assert plane.axis == 0 and abs(plane.offset - 0.5) < 1e-9
