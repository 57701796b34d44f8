"""Mirror symmetry: symmetric meshes get symmetric skeletons; posed or one-sided meshes are left alone."""

from __future__ import annotations

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from simcore.geometry.capsule_creatures import capsule_between, quadruped, stick_humanoid
from simcore.geometry.voxelize import solid_voxels
from simcore.skeleton.geometric import geometric_skeleton
from simcore.skeleton.humanoid import fit_humanoid
from simcore.skeleton.mirror import MirrorPlane
from simcore.skeleton.symmetry import symmetrize

ACROSS_Z = MirrorPlane(2, 0.0)  # the capsule dog's left and right sides are ±z


def _asymmetry(positions: np.ndarray, plane: MirrorPlane) -> float:
    """Largest distance from a joint's mirror image to the nearest joint."""
    return float(cKDTree(positions).query(plane.reflect(positions))[0].max())


def test_the_dogs_geometric_skeleton_is_its_own_mirror_image():
    vertices, faces, _ = quadruped()
    skeleton, report = geometric_skeleton(vertices, faces)
    assert report["mirror"]["axis"] == "z" and report["mirror"]["pairs"] >= 4
    assert _asymmetry(skeleton.positions, ACROSS_Z) < 1e-9  # thinning alone leaves a front knee 0.03 m lower


def test_jittered_twins_are_averaged_and_mid_joints_put_on_the_plane():
    vertices, faces, truth = quadruped()
    noisy = truth.positions + np.random.default_rng(5).normal(0.0, 0.01, truth.positions.shape)
    fixed, report = symmetrize(noisy, truth.parents, solid_voxels(vertices, faces, resolution=96), vertices)
    assert report == {"axis": "z", "pairs": 4, "on_plane": 5}  # knees and feet; pelvis, chest, neck, head, tail
    assert _asymmetry(fixed, ACROSS_Z) < 1e-9
    assert np.abs(fixed[[truth.names.index(n) for n in ("pelvis", "chest", "neck", "head", "tail")], 2]).max() < 1e-12
    assert np.linalg.norm(fixed - truth.positions, axis=1).mean() < np.linalg.norm(noisy - truth.positions, axis=1).mean()


def test_twins_are_matched_by_their_parents_too():
    # The right knee sits low and the right foot tip close under where the left knee's mirror image falls: by
    # position alone the left knee would pair with the right foot tip.
    positions = np.array([[0, 0, 0], [-0.5, 0, 0], [-1.0, 0, 0], [-1.0, -0.3, 0],
                          [0.5, 0, 0], [1.0, -0.05, 0], [1.0, -0.01, 0]], dtype=np.float64)
    parents = np.array([-1, 0, 1, 2, 0, 4, 5])
    box = trimesh.creation.box(extents=(2.4, 1.0, 0.4))  # symmetric across every axis: x, the first, is taken
    fixed, report = symmetrize(positions, parents, solid_voxels(box.vertices, box.faces, resolution=96), box.vertices)
    assert report["axis"] == "x"
    np.testing.assert_allclose(fixed[2], MirrorPlane(0, 0.0).reflect(fixed[5:6])[0])  # knee with knee


def test_a_mesh_that_is_not_symmetric_keeps_its_joints():
    vertices, faces, truth = quadruped()
    sword = capsule_between(np.array([0.4, 0.6, 0.2]), np.array([0.4, 1.6, 0.9]), 0.05)  # held out on one side
    mesh = trimesh.util.concatenate([trimesh.Trimesh(vertices, faces, process=False), sword])
    fixed, report = symmetrize(truth.positions + 0.01, truth.parents, solid_voxels(mesh.vertices, mesh.faces, resolution=96),
                                mesh.vertices)
    assert report == {"axis": None}
    np.testing.assert_array_equal(fixed, truth.positions + 0.01)


def test_the_humanoid_fit_of_a_symmetric_biped_is_symmetric():
    vertices, faces, _ = stick_humanoid("a")
    fit = fit_humanoid(vertices, faces)
    assert fit.skeleton is not None and fit.report["mirror"]["axis"] == "x"
    assert _asymmetry(fit.skeleton.positions, MirrorPlane(0, 0.0)) < 1e-9
