"""Medial-graph simplification: where a limb leaves the body (and the joint put there), spur pruning of mirror twins."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import read_rigged_asset
from simcore.skeleton.geometric import GeometricParams, geometric_skeleton
from simcore.skeleton.graph_simplify import limb_exit, prune_spurs
from simcore.skeleton.limb_rules import with_limb_root
from simcore.skeleton.mirror import MirrorPlane, mirror_plane


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
    assert with_limb_root(nodes, [], adjacency, pos, rad, params, spacing=0.2) == [exit_index]
    far = nodes.index(15)
    assert with_limb_root(nodes, [far], adjacency, pos, rad, params, spacing=0.2) == sorted([exit_index, far])


def test_no_limb_root_next_to_a_joint_near_the_tip_or_off_a_limb():
    nodes, adjacency, pos, rad = _limb()
    params = GeometricParams()
    assert with_limb_root(nodes, [7], adjacency, pos, rad, params, spacing=0.2) == [7]  # a joint 0.05 away
    assert with_limb_root(nodes, [], adjacency, pos, rad, params, spacing=0.8) == []  # under a spacing left
    near_junction = GeometricParams(limb_gap=2.0)  # the junction itself is within 2 × 0.2 of x = 0.3
    assert with_limb_root(nodes, [], adjacency, pos, rad, near_junction, spacing=0.2) == []
    chain = [[1]] + [[i - 1, i + 1] for i in range(1, 20)] + [[19], [], []]  # leaf to leaf: no junction, no limb
    assert with_limb_root(nodes, [], chain, pos, rad, params, spacing=0.2) == []


def _finned_trunk(fin_radius: float):
    """A trunk (radius 0.2) along +z from node 0 to the junction node 9 at z = 0.9, and two fins 0.35 long out
    of it along ±x (nodes 10-16 and 17-23): mirror images across x = 0, each shorter than the spur limit
    (2 × 0.2 junction radius)."""
    trunk = [(0.0, 0.0, 0.1 * k) for k in range(10)]
    fins = [(s * 0.05 * k, 0.0, 0.9) for s in (-1.0, 1.0) for k in range(1, 8)]
    positions = np.array(trunk + fins)
    radius = np.array([0.2] * 10 + [fin_radius] * 14)
    adjacency = [[1]] + [[k - 1, k + 1] for k in range(1, 9)] + [[8, 10, 17]]
    for first in (10, 17):
        adjacency += [[9 if k == first else k - 1] + ([k + 1] if k < first + 6 else []) for k in range(first, first + 7)]
    return adjacency, positions, radius


def _prune(fin_radius: float, plane: MirrorPlane | None) -> set[int]:
    adjacency, positions, radius = _finned_trunk(fin_radius)
    return set(prune_spurs(adjacency, positions, radius, 2.0, 0.0, plane, GeometricParams().twin_slender))


def test_slender_mirror_twin_spurs_are_both_kept():
    assert _prune(0.05, MirrorPlane(0, 0.0)) == set()  # 0.35 long >= 4 × 0.05: a pair of fins


def test_without_a_slender_bound_twin_spurs_are_removed_together():
    adjacency, positions, radius = _finned_trunk(0.05)
    assert set(prune_spurs(adjacency, positions, radius, 2.0, 0.0, MirrorPlane(0, 0.0))) == set(range(10, 24))


def test_stubby_mirror_twin_spurs_are_both_removed():
    assert _prune(0.1, MirrorPlane(0, 0.0)) == set(range(10, 24))  # 0.35 < 4 × 0.1: bumps


def test_without_a_mirror_plane_one_twin_goes_and_the_other_stays_as_the_continuation():
    assert _prune(0.05, None) == set(range(10, 17))  # the old one-at-a-time rule: a one-finned fish


def test_the_fishs_two_pectoral_fins_are_both_rigged(dev_assets):
    """rignet_11814_fish's pectoral fins are spur-length twins off one junction: both get bones. Pruned one at a
    time, one fin went and the other stayed as the junction's continuation, later dropped as a lopsided branch:
    a symmetric skeleton with no fins at all."""
    rig = read_rigged_asset(GltfDocument.from_bytes((dev_assets / "rignet_11814_fish.glb").read_bytes()))
    skeleton, report = geometric_skeleton(rig.vertices, rig.faces)
    plane = mirror_plane(rig.vertices)
    size = float(np.ptp(rig.vertices, axis=0).max())
    side = (skeleton.positions[:, plane.axis] - plane.offset) / size
    assert (side > 0.05).sum() >= 1 and (side < -0.05).sum() >= 1  # a fin joint on each side
    assert report["mirror"]["pairs"] >= 1
    assert cKDTree(skeleton.positions).query(plane.reflect(skeleton.positions))[0].max() < 0.05 * size
