"""Geometric skeleton: a capsule quadruped with a known skeleton, budgets, several bodies, determinism."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from simcore.errors import InvalidInput
from simcore.geometry.capsule_creatures import capsule_between, quadruped, stick_humanoid
from simcore.geometry.voxelize import solid_voxels
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import read_rigged_asset
from simcore.metrics.skeleton import ground_truth_skeleton, unit_cube
from simcore.skeleton.geometric import GeometricParams, _midline_ends, geometric_skeleton
from simcore.skeleton.mirror import MirrorPlane
from simcore.skeleton.predict import predict_skeleton
from simcore.skeleton.symmetry import MirrorTwins
from simcore.skeleton.types import Skeleton
from tests.meshes import joined


def chamfer(a: np.ndarray, b: np.ndarray) -> float:
    return 0.5 * (cKDTree(b).query(a)[0].mean() + cKDTree(a).query(b)[0].mean())


@pytest.fixture(scope="module")
def dog():
    vertices, faces, truth = quadruped()
    skeleton, report = geometric_skeleton(vertices, faces)
    return vertices, faces, truth, skeleton, report


def test_quadruped_skeleton_matches_the_skeleton_it_was_built_on(dog):
    vertices, faces, truth, skeleton, _ = dog
    skeleton.validate()
    scale = np.ptp(vertices, axis=0).max()
    # The built skeleton's leaves are its capsules' end centres, which is where thinning stops: compare before the
    # tip pull (tested below) moves them in to where artists put the last joint.
    raw, _ = geometric_skeleton(vertices, faces, params=GeometricParams(tip_pull=0.0, leg_tip_pull=0.0))
    assert chamfer(raw.positions, truth.positions) / scale < 0.045
    assert 0.5 * truth.num_joints <= skeleton.num_joints <= 2 * truth.num_joints
    leaves = [j for j, kids in enumerate(skeleton.children()) if not kids]
    assert len(leaves) == 6  # four feet, head, tail


def test_joints_lie_inside_the_solid(dog):
    vertices, faces, _, skeleton, report = dog
    grid = solid_voxels(vertices, faces, resolution=report["resolution"])
    assert grid.inside(skeleton.positions).all()


def test_tips_pulled_out_of_the_solid_are_snapped_back_inside(dog):
    vertices, faces, _, _, report = dog
    # A negative pull pushes every leaf a whole bone beyond its limb's end, out of the mesh.
    pushed, _ = geometric_skeleton(vertices, faces, params=GeometricParams(tip_pull=-1.0))
    grid = solid_voxels(vertices, faces, resolution=report["resolution"])
    assert grid.inside(pushed.positions).all()


def test_same_mesh_gives_the_same_skeleton(dog):
    vertices, faces, _, skeleton, _ = dog
    again, _ = geometric_skeleton(vertices.copy(), faces.copy())
    np.testing.assert_array_equal(again.positions, skeleton.positions)
    np.testing.assert_array_equal(again.parents, skeleton.parents)


def test_root_is_a_body_junction_not_a_limb_tip(dog):
    _, _, _, skeleton, _ = dog
    assert len(skeleton.children()[0]) >= 3
    assert 0.4 < skeleton.positions[0, 1] < 0.8  # on the trunk, not down a leg


def test_max_joints_is_respected(dog):
    vertices, faces, _, _, _ = dog
    small, _ = geometric_skeleton(vertices, faces, max_joints=8)
    assert 2 <= small.num_joints <= 8
    small.validate()


def test_separate_bodies_are_joined_into_one_tree():
    a = capsule_between(np.array([0.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), 0.1)
    b = capsule_between(np.array([0.6, 0.0, 0.0]), np.array([0.6, 0.6, 0.0]), 0.1)
    mesh = joined([a, b])
    skeleton, report = geometric_skeleton(mesh.vertices, mesh.faces)
    skeleton.validate()
    assert report["bodies"] == 2 and report["bodies_joined"] == 1
    assert (skeleton.positions[:, 0] > 0.4).any() and (skeleton.positions[:, 0] < 0.2).any()


def test_predict_rejects_empty_meshes_and_unknown_methods(dog):
    vertices, faces, _, _, _ = dog
    with pytest.raises(InvalidInput) as err:
        predict_skeleton(vertices, faces[:0])
    assert err.value.code == "empty_mesh"
    with pytest.raises(InvalidInput) as err:
        predict_skeleton(vertices, faces, method="magic")
    assert err.value.field == "options.skeleton"
    for option in ("up_axis", "forward_axis"):  # whichever method runs (the geometric one reads no facing)
        with pytest.raises(InvalidInput) as err:
            axis: dict[str, Any] = {option: "sideways"}
            predict_skeleton(vertices, faces, method="geometric", **axis)
        assert err.value.field == f"options.{option}"


def test_predict_geometric_reports_method_and_timing(dog):
    vertices, faces, _, skeleton, _ = dog
    prediction = predict_skeleton(vertices, faces, method="geometric")
    assert prediction.method == "geometric"
    assert prediction.report["timings_s"]["geometric"] >= 0
    np.testing.assert_array_equal(prediction.skeleton.positions, skeleton.positions)


def test_flat_strip_gets_a_joint_where_each_segment_starts():
    # The glTF SimpleSkin layout: a 1 × 2 strip in the XY plane, no thickness to voxelise.
    xs, ys = np.meshgrid([-0.5, 0.5], np.linspace(0.0, 2.0, 5))
    vertices = np.column_stack([xs.ravel(), ys.ravel(), np.zeros(10)])
    faces = np.array([[2 * i, 2 * i + 1, 2 * i + 3] for i in range(4)] + [[2 * i, 2 * i + 3, 2 * i + 2] for i in range(4)])
    skeleton, report = geometric_skeleton(vertices, faces)
    assert report["sheet"] is True
    # Rooted at the lower end; a joint where each of its two width-long segments starts, none on the far edge
    # (SimpleSkin's own rig).
    np.testing.assert_allclose(skeleton.positions, [[0, 0, 0], [0, 1, 0]], atol=1e-9)
    assert skeleton.parents.tolist() == [-1, 0]


def test_two_solids_far_apart_are_not_a_sheet():
    # A figure and a prop 30 m away are flat as a whole (2 % of the length thick); a sheet chain would put its
    # joints in the empty space between them.
    figure = capsule_between(np.array([0.0, 0.2, 0.0]), np.array([0.0, 1.5, 0.0]), 0.25)
    prop = capsule_between(np.array([30.0, 0.2, 0.0]), np.array([30.0, 1.0, 0.0]), 0.05)
    vertices = np.vstack([figure.vertices, prop.vertices])
    faces = np.vstack([figure.faces, prop.faces + len(figure.vertices)])
    skeleton, report = geometric_skeleton(vertices, faces)
    assert "sheet" not in report and report["bodies"] == 2
    gap = (skeleton.positions[:, 0] > 1.0) & (skeleton.positions[:, 0] < 29.0)
    assert not gap.any(), skeleton.positions


def test_a_flag_with_a_button_is_still_a_sheet():
    xs, ys = np.meshgrid([-0.5, 0.5], np.linspace(0.0, 2.0, 5))
    flag_v = np.column_stack([xs.ravel(), ys.ravel(), np.zeros(10)])
    flag_f = np.array([[2 * i, 2 * i + 1, 2 * i + 3] for i in range(4)] + [[2 * i, 2 * i + 3, 2 * i + 2] for i in range(4)])
    button = trimesh.creation.icosphere(subdivisions=1, radius=0.02)  # under 1 % of the area: not deciding
    vertices = np.vstack([flag_v, button.vertices + [0.0, 1.0, 0.03]])
    faces = np.vstack([flag_f, button.faces + len(flag_v)])
    _, report = geometric_skeleton(vertices, faces)
    assert report["sheet"] is True


@pytest.mark.parametrize(("axis", "label"), [(1, "upright: lower end"), (2, "level: back (-Z) end")])
def test_a_tube_is_one_chain_rooted_at_an_end(axis: int, label: str):
    start, end = np.zeros(3), np.zeros(3)
    start[axis], end[axis] = 0.3, 1.8  # the end with the smaller coordinate must become the root
    tube = capsule_between(end, start, 0.08)
    skeleton, _ = geometric_skeleton(tube.vertices, tube.faces)
    assert skeleton.num_joints >= 3, label
    assert skeleton.parents.tolist() == list(range(-1, skeleton.num_joints - 1)), label  # one path from the root
    along = skeleton.positions[:, axis]
    assert along[0] < 0.3 + 0.1 and np.all(np.diff(along) > 0), label
    steps = np.diff(along)  # evenly spaced joints, except the tip, pulled back towards its parent
    assert steps[-1] < 0.8 * np.median(steps[:-1]), label


def test_a_chains_root_is_pushed_out_towards_the_tubes_end():
    tube = capsule_between(np.array([0.0, 0.3, 0.0]), np.array([0.0, 1.9, 0.0]), 0.2)
    skeleton, _ = geometric_skeleton(tube.vertices, tube.faces)
    # Thinning stops about a radius inside the cap; the chain's root is pushed half a radius out, towards the end.
    flush, _ = geometric_skeleton(tube.vertices, tube.faces, params=GeometricParams(root_push=0.0))
    np.testing.assert_allclose(skeleton.positions[1:], flush.positions[1:])
    drop = flush.positions[0, 1] - skeleton.positions[0, 1]
    assert 0.05 < drop < 0.15
    assert skeleton.positions[0, 1] > 0.1  # still inside the mesh (the cap's tip is at y = 0.1)


def _pulled_share(vertices: np.ndarray, faces: np.ndarray, picked) -> np.ndarray:
    """How far (share of the way to the parent) the leaves `picked(positions) -> mask` were moved in (with no
    sub-voxel centring, which moves them across their bone afterwards)."""
    unpulled = GeometricParams(tip_pull=0.0, leg_tip_pull=0.0, section_limit=0.0)
    raw, _ = geometric_skeleton(vertices, faces, params=unpulled)
    pulled, _ = geometric_skeleton(vertices, faces, params=GeometricParams(section_limit=0.0))
    assert raw.parents.tolist() == pulled.parents.tolist()
    leaf = np.setdiff1d(np.arange(raw.num_joints), raw.parents)
    leaf = leaf[picked(raw.positions[leaf])]
    step = raw.positions[raw.parents[leaf]] - raw.positions[leaf]
    return np.einsum("ij,ij->i", pulled.positions[leaf] - raw.positions[leaf], step) / np.einsum("ij,ij->i", step, step)


def test_limb_tips_are_pulled_towards_their_parent_joint(dog):
    params = GeometricParams()
    assert 0.0 < params.leg_tip_pull < params.tip_pull < 1.0  # a leaf on its parent would be a zero-length bone
    feet = _pulled_share(dog[0], dog[1], lambda p: p[:, 1] < 0.3)
    np.testing.assert_allclose(feet, params.leg_tip_pull, atol=1e-9)  # legs standing on the floor
    vertices, faces, _ = stick_humanoid()
    hands = _pulled_share(vertices, faces, lambda p: np.abs(p[:, 0]) > 0.5)
    assert len(hands) == 2
    np.testing.assert_allclose(hands, params.tip_pull, atol=1e-9)


def test_the_ends_of_a_head_and_a_tail_get_no_joint_a_rope_keeps_its_end(dog):
    vertices, faces, truth, skeleton, report = dog
    assert report["mirror"]["midline_ends_dropped"] == 2
    head, tail = truth.positions[truth.names.index("head")], truth.positions[truth.names.index("tail")]
    for end, inner in ((head, truth.positions[truth.names.index("neck")]), (tail, truth.positions[0])):
        nearest = skeleton.positions[np.argmin(np.linalg.norm(skeleton.positions - end, axis=1))]
        assert np.linalg.norm(nearest - end) > 0.25 * np.linalg.norm(end - inner)  # no joint out at the tip
    rope = capsule_between(np.array([0.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), 0.05)
    chain, chain_report = geometric_skeleton(np.asarray(rope.vertices), np.asarray(rope.faces))
    assert chain_report["mirror"]["midline_ends_dropped"] == 0 and chain.positions[:, 1].max() > 0.8


def test_a_head_hanging_straight_from_the_body_keeps_its_only_joint():
    """Root junction with two wings, a head that is a single leaf, and a tail whose pivot forks into two lobes on
    the mid-plane: the head's joint stays (it is the head's only bone), both lobe tips go (one part's end)."""
    positions = np.array([[0, 0, 0], [-1, 0, 0], [1, 0, 0], [0, -0.5, 0], [0, -1, 0.1], [0, 0.5, 0],
                          [0, -1, -0.1]], float)
    parents = np.array([-1, 0, 0, 0, 3, 0, 3])
    skeleton = Skeleton(positions, parents, [f"j{k}" for k in range(7)])
    twins = MirrorTwins(MirrorPlane(0, 0.0), np.array([0, 2, 1, 3, 4, 5, 6]), 2.0)
    assert _midline_ends(skeleton, twins).tolist() == [False, False, False, False, True, False, True]


def test_a_round_head_gets_one_joint_at_its_neck_and_none_inside(dog):
    """The capsule dog with a ball of a head, 2.4 × as thick as its neck: the neck keeps its joints, the head pivots
    where the neck meets it, and no joint lies inside the skull (without the rule one sat 0.16 from its centre)."""
    vertices, faces, truth, _, _ = dog
    centre, radius = np.array([1.1, 0.95, 0.0]), 0.24
    ball = trimesh.creation.icosphere(subdivisions=3, radius=radius)
    ball.apply_translation(centre)
    with_ball = np.vstack([vertices, ball.vertices]), np.vstack([faces, ball.faces + len(vertices)])
    skeleton, _ = geometric_skeleton(*with_ball)
    to_centre = np.linalg.norm(skeleton.positions - centre, axis=1)
    assert to_centre.min() > radius  # nothing inside the skull
    neck = truth.positions[truth.names.index("neck")]
    assert np.linalg.norm(skeleton.positions - neck, axis=1).min() < 0.1  # the neck keeps its joint
    assert np.sort(to_centre)[0] < radius + 0.15  # the head's pivot is where the neck meets it


def test_the_bats_head_keeps_a_joint(dev_assets):
    """The bat's head thins to one branch straight from the body's junction. Its artist's head joint (the highest)
    is 0.070 from our nearest joint (unit-cube units), 0.112 when the head's joint was dropped as a midline end."""
    rig = read_rigged_asset(GltfDocument.from_bytes((dev_assets / "rignet_15930_bat.glb").read_bytes()))
    skeleton, _ = geometric_skeleton(rig.vertices, rig.faces)
    norm = unit_cube(rig.vertices)
    artist = norm.to_unit(ground_truth_skeleton(rig).positions)
    head = artist[np.argmax(artist[:, 1])]
    assert np.linalg.norm(norm.to_unit(skeleton.positions) - head, axis=1).min() < 0.08


def _leg_chains(skeleton) -> list[int]:
    """Joint counts of the chains ending at the leaves below the body (y < 0.3 on the capsule dog)."""
    children = skeleton.children()
    counts = []
    for leaf in (j for j, kids in enumerate(children) if not kids and skeleton.positions[j, 1] < 0.3):
        chain = [leaf]
        while skeleton.parents[chain[-1]] > 0 and len(children[skeleton.parents[chain[-1]]]) == 1:
            chain.append(int(skeleton.parents[chain[-1]]))
        counts.append(len(chain))
    return counts


def test_legs_standing_on_the_floor_get_hip_knee_ankle_and_foot(dog):
    vertices, faces, _, skeleton, _ = dog
    assert _leg_chains(skeleton) == [4, 4, 4, 4]  # an even split by the spacing gave knee and foot only
    lying = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])  # +Y up → +Z up
    told, _ = geometric_skeleton(vertices @ lying.T, faces, up=np.array([0, 0, 1.0]))
    assert _leg_chains(Skeleton(told.positions @ lying, told.parents, told.names)) == [4, 4, 4, 4]
    option = predict_skeleton(vertices @ lying.T, faces, method="geometric", up_axis="z").skeleton
    assert _leg_chains(Skeleton(option.positions @ lying, option.parents, option.names)) == [4, 4, 4, 4]
    untold, _ = geometric_skeleton(vertices @ lying.T, faces)  # +Y is sideways there: no legs on that floor
    assert _leg_chains(Skeleton(untold.positions @ lying, untold.parents, untold.names)) == [2, 2, 2, 2]


def _ring_round_a_slit(top: float, bottom: float) -> trimesh.Trimesh:
    # Capsule bars of radius `top` and `bottom` round a 0.07 m (≈ 4 voxel) slit, joined at both ends, plus a tail.
    gap = 0.07
    upper, lower = top + gap / 2, -(bottom + gap / 2)
    ends = [((0, upper), (1, upper), top), ((0, lower), (1, lower), bottom), ((0, upper), (0, lower), bottom),
            ((1, upper), (1, lower), bottom), ((1, upper), (1.6, upper), 0.06)]
    return joined([capsule_between(np.array([*a, 0.0]), np.array([*b, 0.0]), r) for a, b, r in ends])


def test_cavity_in_a_body_is_closed_so_the_skeleton_runs_through_the_body():
    # A thick head over a thin jaw loop (a fish head round its mouth): the closed axis runs through the head.
    mesh = _ring_round_a_slit(top=0.14, bottom=0.05)
    skeleton, report = geometric_skeleton(mesh.vertices, mesh.faces)
    looped, looped_report = geometric_skeleton(mesh.vertices, mesh.faces, params=GeometricParams(close_retry=1))
    assert report["close_radius"] == 2 and looped_report["close_radius"] == 1
    assert looped.positions[:, 1].min() < -0.05  # without the retry, thinning traces round the jaw
    # With it, one chain through the head; only its end may dip into the filled jaw's corner (a restored limb).
    assert np.bincount(skeleton.parents[1:], minlength=skeleton.num_joints).max() == 1
    below = skeleton.positions[skeleton.positions[:, 1] < 0.0]
    assert len(below) <= 1 and (below[:, 0] < 0.15).all()
    assert skeleton.num_joints < looped.num_joints
    assert solid_voxels(mesh.vertices, mesh.faces, resolution=report["resolution"]).inside(skeleton.positions).all()


def test_gap_between_equal_parts_is_not_bridged():
    # Two equal bars round a slit: closing would put the axis in the empty slit, outside the mesh.
    mesh = _ring_round_a_slit(top=0.08, bottom=0.08)
    skeleton, report = geometric_skeleton(mesh.vertices, mesh.faces)
    assert report["close_radius"] == 1
    assert solid_voxels(mesh.vertices, mesh.faces, resolution=report["resolution"]).inside(skeleton.positions).all()


def test_meshes_without_cavities_keep_the_light_closing(dog):
    _, _, _, _, report = dog
    assert report["close_radius"] == 1
