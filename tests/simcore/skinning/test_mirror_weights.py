"""Mirror-symmetric weights: a symmetric character's two sides get mirror-image weights; joints without a twin
(a prop on one side) and asymmetric meshes are left alone."""

from __future__ import annotations

import numpy as np

from simcore.geometry.capsule_creatures import quadruped
from simcore.skeleton.types import Skeleton
from simcore.skinning.mirror_weights import weight_mirror
from simcore.skinning.predict import compute_weights


def _swap_sides(names: list[str]) -> list[int]:
    """Each name's index after swapping `_l_` and `_r_`."""
    index = {name: i for i, name in enumerate(names)}
    return [index[n.replace("_l_", "#").replace("_r_", "_l_").replace("#", "_r_")] for n in names]


def test_the_quadrupeds_legs_pair_across_its_plane_and_mirrored_rows_match():
    vertices, _, skeleton = quadruped()
    mirror = weight_mirror(vertices, skeleton)
    assert mirror is not None and mirror.report()["axis"] == "z" and np.mean(mirror.vertex_twin >= 0) > 0.95
    np.testing.assert_array_equal(mirror.joint_twin, _swap_sides(skeleton.names))
    noisy = np.random.default_rng(0).random((len(vertices), skeleton.num_joints))
    out = mirror.apply(noisy / noisy.sum(axis=1, keepdims=True))
    rows = np.flatnonzero(mirror.vertex_twin >= 0)
    np.testing.assert_allclose(out[rows][:, mirror.joint_twin], out[mirror.vertex_twin[rows]], atol=1e-12)
    np.testing.assert_allclose(out.sum(axis=1), 1.0)


def test_a_jobs_weights_on_a_symmetric_creature_are_mirror_images():
    vertices, faces, skeleton = quadruped()
    result = compute_weights(vertices, faces, skeleton, method="geodesic")
    assert result.mirror is not None
    mirror = weight_mirror(vertices, skeleton)
    assert mirror is not None
    weights = result.weights.toarray()
    rows = np.flatnonzero(mirror.vertex_twin >= 0)
    assert np.abs(weights[rows][:, mirror.joint_twin] - weights[mirror.vertex_twin[rows]]).sum(axis=1).max() < 1e-5


def test_a_prop_joint_on_one_side_keeps_its_vertices_own_weights():
    vertices, _, skeleton = quadruped()
    foot = skeleton.names.index("front_l_foot")
    rig = Skeleton(np.vstack([skeleton.positions, skeleton.positions[foot] + [0.0, 0.1, 0.0]]),
                   np.append(skeleton.parents, foot), [*skeleton.names, "prop"])
    mirror = weight_mirror(vertices, rig)
    assert mirror is not None and mirror.joint_twin[-1] == -1
    weights = np.zeros((len(vertices), rig.num_joints))
    weights[:, 0] = 1.0
    near_prop = np.linalg.norm(vertices - rig.positions[-1], axis=1) < 0.1
    weights[near_prop] = 0.0
    weights[near_prop, -1] = 1.0
    out = mirror.apply(weights)
    np.testing.assert_array_equal(out[near_prop], weights[near_prop])  # the prop's vertices stay as they were
    twins_of_prop = mirror.vertex_twin[near_prop]
    np.testing.assert_array_equal(out[twins_of_prop[twins_of_prop >= 0]], weights[twins_of_prop[twins_of_prop >= 0]])


def test_a_root_copied_per_limb_pairs_each_copy_with_its_limbs_mirror():
    """RigNet's rigs repeat the root once per limb at one place: each copy must map to the copy of the mirror limb."""
    vertices, _, _ = quadruped()
    up = [0.0, 0.5, 0.0]
    positions = np.array([up, up, up, [0.0, 0.5, 0.2], [0.0, 0.5, -0.2]])
    rig = Skeleton(positions, np.array([-1, 0, 0, 1, 2]), ["root", "copy_a", "copy_b", "left", "right"])
    mirror = weight_mirror(vertices, rig)
    assert mirror is not None
    np.testing.assert_array_equal(mirror.joint_twin, [0, 2, 1, 4, 3])


def test_an_asymmetric_mesh_is_not_mirrored():
    vertices, _, skeleton = quadruped()
    bent = vertices.copy()
    bent[bent[:, 2] > 0.0, 1] += 0.3  # one side raised: no longer its own mirror image
    assert weight_mirror(bent, skeleton) is None


def test_a_mesh_whose_sides_do_not_mirror_vertex_for_vertex_is_left_alone():
    """Jittered by 0.3 % of its size, the quadruped still mirrors as a shape, but few vertices keep an exact twin:
    averaging those few rows alone would make them differ from their neighbours'."""
    vertices, _, skeleton = quadruped()
    size = float(np.ptp(vertices, axis=0).max())
    jittered = vertices + np.random.default_rng(1).normal(scale=0.003 * size, size=vertices.shape)
    assert weight_mirror(vertices, skeleton) is not None
    assert weight_mirror(jittered, skeleton) is None
