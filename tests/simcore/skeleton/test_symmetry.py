"""Mirror symmetry: symmetric meshes get symmetric skeletons; posed or one-sided meshes are left alone."""

from __future__ import annotations

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from simcore.geometry.capsule_creatures import capsule_between, quadruped, soup, stick_humanoid
from simcore.geometry.voxelize import solid_voxels
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import read_rigged_asset
from simcore.skeleton.geometric import geometric_skeleton
from simcore.skeleton.humanoid import fit_humanoid
from simcore.skeleton.mirror import MirrorPlane
from simcore.skeleton.symmetry import body_mirror, complete_twins, lopsided_branches, mirror_report, mirror_twins, symmetrize
from simcore.skeleton.types import Skeleton
from tests.meshes import joined

ACROSS_Z = MirrorPlane(2, 0.0)  # the capsule dog's left and right sides are ±z


def _asymmetry(positions: np.ndarray, plane: MirrorPlane) -> float:
    """Largest distance from a joint's mirror image to the nearest joint."""
    return float(cKDTree(positions).query(plane.reflect(positions))[0].max())


def _solid(mesh: trimesh.Trimesh):
    return solid_voxels(mesh.vertices, mesh.faces, resolution=96)


def _skeleton(positions: np.ndarray, parents: np.ndarray) -> Skeleton:
    return Skeleton(positions, parents, [f"j{k}" for k in range(len(positions))])


def _twins(positions: np.ndarray, parents: np.ndarray, grid, vertices: np.ndarray):
    plane = body_mirror(vertices)
    assert plane is not None
    return mirror_twins(positions, parents, grid, plane)


def test_the_dogs_geometric_skeleton_is_its_own_mirror_image():
    vertices, faces, _ = quadruped()
    skeleton, report = geometric_skeleton(vertices, faces)
    assert report["mirror"]["axis"] == "z" and report["mirror"]["pairs"] >= 4
    assert _asymmetry(skeleton.positions, ACROSS_Z) < 1e-9  # thinning alone leaves a front knee 0.03 m lower


def test_jittered_twins_are_averaged_and_mid_joints_put_on_the_plane():
    vertices, faces, truth = quadruped()
    noisy = truth.positions + np.random.default_rng(5).normal(0.0, 0.01, truth.positions.shape)
    twins = _twins(noisy, truth.parents, solid_voxels(vertices, faces, resolution=96), vertices)
    assert mirror_report(twins) == {"axis": "z", "pairs": 4, "on_plane": 5, "lopsided_dropped": 0, "twins_added": 0,
                                    "midline_ends_dropped": 0}
    fixed = symmetrize(noisy, twins)  # pairs: knees and feet; on the plane: pelvis, chest, neck, head, tail
    assert _asymmetry(fixed, ACROSS_Z) < 1e-9
    assert np.abs(fixed[[truth.names.index(n) for n in ("pelvis", "chest", "neck", "head", "tail")], 2]).max() < 1e-12
    assert np.linalg.norm(fixed - truth.positions, axis=1).mean() < np.linalg.norm(noisy - truth.positions, axis=1).mean()


def _box_creature():
    """Joints of a creature in a box with a hump, symmetric across x: a root, a left leg
    (hip, knee, foot tip) and a right leg whose knee sits low with its foot tip close under where the left
    knee's mirror image falls."""
    positions = np.array([[0, 0, 0], [-0.5, 0, 0], [-1.0, 0, 0], [-1.0, -0.3, 0],
                          [0.5, 0, 0], [1.0, -0.05, 0], [1.0, -0.01, 0]], dtype=np.float64)
    hump = trimesh.creation.box(extents=(0.4, 0.3, 0.3),
                                transform=trimesh.transformations.translation_matrix([0, 0.6, 0.1]))
    body = joined([trimesh.creation.box(extents=(2.4, 1.0, 0.4)), hump])  # mirrors across x only
    return positions, np.array([-1, 0, 1, 2, 0, 4, 5]), _solid(body), body.vertices


def test_twins_are_matched_by_their_parents_too():
    positions, parents, grid, vertices = _box_creature()
    twins = _twins(positions, parents, grid, vertices)
    assert twins.plane.axis == 0 and twins.twin[2] == 5  # knee with knee: by position alone, with the foot tip
    fixed = symmetrize(positions, twins)
    np.testing.assert_allclose(fixed[2], twins.plane.reflect(fixed[5:6])[0])


def test_a_twinless_branch_is_dropped_when_the_body_has_its_part_on_the_other_side():
    positions, parents, grid, vertices = _box_creature()
    positions = np.concatenate([positions, [[0.5, 0.2, 0.0], [0.8, 0.3, 0.0]]])  # a right-side-only branch...
    parents = np.concatenate([parents, [0, 7]])
    drop = lopsided_branches(_skeleton(positions, parents), _twins(positions, parents, grid, vertices), grid)
    assert np.flatnonzero(drop).tolist() == [7, 8]  # ...inside the box on the left too
    one = lopsided_branches(_skeleton(positions[:8], parents[:8]), _twins(positions[:8], parents[:8], grid, vertices),
                            grid)
    assert not one.any()  # a single twinless joint is left: a joint spacing that differs, not a branch
    near = np.concatenate([positions, [[-0.8, 0.28, 0.0]]])  # a left-side joint by the branch's mirror image
    parents = np.concatenate([parents, [0]])
    kept = lopsided_branches(_skeleton(near, parents), _twins(near, parents, grid, vertices), grid)
    assert not kept.any()  # bones on the other side, placed differently: not a one-sided branch


def test_a_joint_found_on_one_side_only_gets_its_twin_on_the_other():
    _, _, grid, vertices = _box_creature()
    positions = np.array([[0, 0, 0], [-0.5, 0, 0], [-1.0, 0, 0], [-1.0, -0.3, 0], [0.5, 0, 0], [1.0, 0, 0]], float)
    parents = np.array([-1, 0, 1, 2, 0, 4])  # the left leg ends in a foot tip, the right one at its knee
    skeleton = _skeleton(positions, parents)
    twins = _twins(positions, parents, grid, vertices)
    whole, drop, added = complete_twins(skeleton, twins, grid, np.zeros(6, bool))
    assert added == 1 and not drop.any() and whole.validate().num_joints == 7
    tip = int(np.argmin(np.linalg.norm(whole.positions - [1.0, -0.3, 0.0], axis=1)))
    np.testing.assert_allclose(whole.positions[tip], [1.0, -0.3, 0.0])
    np.testing.assert_allclose(whole.positions[whole.parents[tip]], [1.0, 0.0, 0.0])  # under the right knee
    assert complete_twins(skeleton, twins, grid, np.array([0, 0, 0, 0, 0, 1], bool))[2] == 0  # knee dropped
    assert complete_twins(skeleton, twins, grid, np.zeros(6, bool), max_joints=6)[2] == 0  # no room in the budget
    near = _skeleton(np.vstack([positions, [[1.0, -0.27, 0.0]]]), np.append(parents, 0))  # a joint by the image
    assert complete_twins(near, _twins(near.positions, near.parents, grid, vertices), grid, np.zeros(7, bool))[2] == 0


def test_two_twinless_joints_side_by_side_get_one_image_not_two_on_one_spot():
    """A foot tip and a toe 0.015 apart on the left, none on the right: their mirror images would coincide."""
    _, _, grid, vertices = _box_creature()
    positions = np.array([[0, 0, 0], [-0.5, 0, 0], [-1.0, 0, 0], [-1.0, -0.3, 0], [-1.0, -0.3, 0.015], [0.5, 0, 0],
                          [1.0, 0, 0]], float)
    parents = np.array([-1, 0, 1, 2, 2, 0, 5])
    skeleton = _skeleton(positions, parents)
    whole, _, added = complete_twins(skeleton, _twins(positions, parents, grid, vertices), grid, np.zeros(7, bool))
    assert added == 1
    assert np.linalg.norm(whole.positions[whole.positions[:, 0] > 0.9] - [1.0, -0.3, 0.0], axis=1).min() < 0.02


def test_a_chain_one_joint_longer_on_one_side_gets_the_joint_on_the_other():
    _, _, grid, vertices = _box_creature()
    positions = np.array([[0, 0, 0], [-0.5, 0, 0], [-0.8, -0.1, 0], [-1.0, -0.3, 0], [0.5, 0, 0], [1.0, -0.3, 0]],
                         float)
    parents = np.array([-1, 0, 1, 2, 0, 4])  # hip, knee, foot on the left; hip, foot on the right
    skeleton = _skeleton(positions, parents)
    whole, _, added = complete_twins(skeleton, _twins(positions, parents, grid, vertices), grid, np.zeros(6, bool))
    assert added == 1
    whole.validate()
    chain = [int(np.argmin(np.linalg.norm(whole.positions - p, axis=1))) for p in ([0.5, 0, 0], [0.8, -0.1, 0],
                                                                                       [1.0, -0.3, 0])]
    np.testing.assert_allclose(whole.positions[chain[1]], [0.8, -0.1, 0.0])
    assert whole.parents[chain[1]] == chain[0] and whole.parents[chain[2]] == chain[1]  # hip → knee → foot


def test_the_foxs_hind_feet_both_get_their_tip_joint(dev_assets):
    """Thinning left one of the fox's hind feet a voxel short, and that leg one joint short (0.039 × size off)."""
    rig = read_rigged_asset(GltfDocument.from_bytes((dev_assets / "fox.glb").read_bytes()))
    skeleton, report = geometric_skeleton(rig.vertices, rig.faces)
    assert report["mirror"]["twins_added"] == 1
    size = float(np.ptp(rig.vertices, axis=0).max())
    plane = body_mirror(rig.vertices)
    assert plane is not None and _asymmetry(skeleton.positions, plane) < 1e-6 * size


def test_averaging_twins_leaves_no_zero_length_bone(dev_assets):
    """On the bird's right foot a twinless joint and its child (paired with a left-foot joint) were averaged onto
    the same point: a bone of length 0, with no direction to rotate about. The child goes; its own children stay."""
    rig = read_rigged_asset(GltfDocument.from_bytes((dev_assets / "rignet_17872_bird.glb").read_bytes()))
    skeleton, report = geometric_skeleton(rig.vertices, rig.faces)
    pitch = report["voxel_pitch"]
    bones = np.linalg.norm(skeleton.positions[1:] - skeleton.positions[skeleton.parents[1:]], axis=1)
    assert bones.min() > pitch


def test_a_dog_holding_a_sword_out_to_one_side_is_not_symmetrized():
    vertices, faces, _ = quadruped()
    sword = capsule_between(np.array([0.4, 0.6, 0.2]), np.array([0.4, 1.6, 0.9]), 0.05)
    mesh = joined([trimesh.Trimesh(vertices, faces, process=False), sword])
    assert body_mirror(mesh.vertices) is None
    assert geometric_skeleton(mesh.vertices, mesh.faces)[1]["mirror"] == {"axis": None}


def test_a_posed_dog_keeps_its_posed_leg_where_it_is():
    """One front leg swung forward (mid-stride): the mesh is no longer its own mirror image, so no joint is
    averaged with a twin (that would pull both front legs' joints between the legs)."""
    _, _, truth = quadruped()
    posed = truth.positions.copy()
    knee, foot = truth.names.index("front_l_knee"), truth.names.index("front_l_foot")
    posed[knee] += [0.3, 0.1, 0.0]
    posed[foot] += [0.6, 0.15, 0.0]
    vertices, faces = soup(Skeleton(posed, truth.parents, truth.names), {c: 0.16 if truth.names[c] == "chest" else 0.06
                                                                        for c in range(1, truth.num_joints)})
    assert body_mirror(vertices) is None
    skeleton, report = geometric_skeleton(vertices, faces)
    assert report["mirror"] == {"axis": None}
    assert cKDTree(skeleton.positions).query(posed[knee])[0] < 0.1  # the swung knee still has its joint


def test_the_humanoid_fit_of_a_symmetric_biped_is_symmetric():
    vertices, faces, _ = stick_humanoid("a")
    fit = fit_humanoid(vertices, faces)
    assert fit.skeleton is not None and fit.report["mirror"]["axis"] == "x"
    assert _asymmetry(fit.skeleton.positions, MirrorPlane(0, 0.0)) < 1e-9


def test_the_robots_one_sided_head_branch_is_dropped(dev_assets):
    """robot_expressive's head thins into a left and a right branch; spur pruning kept the right one only, a
    two-joint branch 0.15 × size from any mirror twin. It goes, and what is left mirrors itself within 0.035."""
    rig = read_rigged_asset(GltfDocument.from_bytes((dev_assets / "robot_expressive.glb").read_bytes()))
    skeleton, report = geometric_skeleton(rig.vertices, rig.faces)
    assert report["mirror"]["axis"] == "x" and report["mirror"]["lopsided_dropped"] == 1
    size = float(np.ptp(rig.vertices, axis=0).max())
    plane = MirrorPlane(0, float(rig.vertices.mean(axis=0)[0]))
    assert _asymmetry(skeleton.positions, plane) < 0.035 * size


def test_the_soldiers_fingers_mirror_their_namesakes(dev_assets):
    """The Mixamo fit's Left…/Right… joints are twins by name: by position alone the soldier's first finger
    joints found no twins (neighbouring fingers' mirror images nearly coincide) and stayed 0.006-0.017 off."""
    rig = read_rigged_asset(GltfDocument.from_bytes((dev_assets / "soldier.glb").read_bytes()))
    fit = fit_humanoid(rig.vertices, rig.faces)
    assert fit.skeleton is not None, fit.report
    names, pos = fit.skeleton.names, fit.skeleton.positions
    axis = "xyz".index(fit.report["mirror"]["axis"])
    plane = MirrorPlane(axis, float(rig.vertices[:, axis].mean()))
    left = [i for i, n in enumerate(names) if "Left" in n]
    right = [names.index(names[i].replace("Left", "Right")) for i in left]
    np.testing.assert_allclose(plane.reflect(pos[left]), pos[right], atol=1e-9)
