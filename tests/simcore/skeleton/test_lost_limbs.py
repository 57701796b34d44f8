"""Lost limbs: a protrusion with no medial voxel gets its medial line back; blob ends and thin tips do not."""

from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from simcore.geometry.voxelize import solid_voxels
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import read_rigged_asset
from simcore.metrics.skeleton import ground_truth_skeleton
from simcore.skeleton.geometric import GeometricParams, geometric_skeleton
from simcore.skeleton.lost_limbs import restore_lost_limbs
from simcore.skeleton.medial import medial_forest

SHAPE = (80, 60, 60)


def _ball(centre: tuple[int, int, int], radius: float) -> np.ndarray:
    i, j, k = np.indices(SHAPE)
    return (i - centre[0]) ** 2 + (j - centre[1]) ** 2 + (k - centre[2]) ** 2 <= radius**2


def _rod(x0: int, x1: int, radius: float) -> np.ndarray:
    """A cylinder along x through (·, 30, 30)."""
    i, j, k = np.indices(SHAPE)
    return (i >= x0) & (i <= x1) & ((j - 30) ** 2 + (k - 30) ** 2 <= radius**2)


def _line(x0: int, x1: int) -> np.ndarray:
    thin = np.zeros(SHAPE, bool)
    thin[x0:x1 + 1, 30, 30] = True
    return thin


def _restore(occupancy: np.ndarray, thin: np.ndarray) -> tuple[np.ndarray, int]:
    return restore_lost_limbs(occupancy, thin, ndimage.distance_transform_edt(occupancy))


def test_a_limb_without_medial_voxels_gets_a_connected_line_stopped_a_radius_short_of_its_tip():
    body = _ball((22, 30, 30), 14)
    limb = _rod(22, 70, 4)  # reaches 34 voxels beyond the body's ball, 4 voxels thick
    thin = _line(20, 24)  # what thinning kept: the body's centre only, as it did with the penguin's head
    restored, count = _restore(body | limb, thin)
    assert count == 1
    added = np.argwhere(restored & ~thin)
    assert 70 - 4 <= added[:, 0].max() < 70  # short of the flat tip by its depth there, as thinning stops
    assert added[:, 0].min() <= 25 and np.abs(added[:, 1:] - 30).max() <= 1  # down the limb's axis to the body
    labels, parts = ndimage.label(restored, structure=np.ones((3, 3, 3), bool))
    assert parts == 1  # joined to what thinning kept


def test_a_blob_end_and_a_thin_tip_are_not_taken_for_limbs():
    # A capsule body whose thinning stopped short of both ends: shallow caps, reaching ~2x their own depth.
    capsule = _rod(20, 60, 12) | _ball((20, 30, 30), 12) | _ball((60, 30, 30), 12)
    thin = _line(26, 54)
    assert _restore(capsule, thin)[1] == 0
    # A spike one voxel thick (an ear tip): left to the tip handling, however long.
    spike = _ball((22, 30, 30), 14) | _rod(22, 70, 1)
    assert _restore(spike, _line(20, 24))[1] == 0


def test_limbs_already_thinned_are_left_as_they_are():
    occupancy = _ball((22, 30, 30), 14) | _rod(22, 70, 4)
    thin = _line(20, 66)
    restored, count = _restore(occupancy, thin)
    assert count == 0 and np.array_equal(restored, thin)


def test_the_penguins_head_gets_bones(dev_assets):
    """Thinning erases rignet_8184_penguin's head (its artist rig has a head chain); the restored forest and the
    geometric skeleton reach it."""
    rig = read_rigged_asset(GltfDocument.from_bytes((dev_assets / "rignet_8184_penguin.glb").read_bytes()))
    truth = ground_truth_skeleton(rig)
    head = truth.positions[int(np.argmax(truth.positions[:, 1]))]  # the artist's highest joint
    size = float(np.ptp(rig.vertices, axis=0).max())
    grid = solid_voxels(rig.vertices, rig.faces, resolution=GeometricParams().resolution)
    plain, restored = medial_forest(grid), medial_forest(grid, restore_limbs=True)
    assert cKDTree(plain.positions).query(head)[0] > 0.1 * size  # the premise: thinning alone misses the head
    assert restored.restored >= 1 and cKDTree(restored.positions).query(head)[0] < 0.05 * size
    skeleton, report = geometric_skeleton(rig.vertices, rig.faces)
    assert report["limbs_restored"] >= 1
    assert cKDTree(skeleton.positions).query(head)[0] < 0.06 * size
