"""Sub-voxel joint placement: chain joints move towards their limb's cross-section centre, by at most a cap."""

from __future__ import annotations

import numpy as np
import pytest

from simcore.geometry.capsule_creatures import capsule_between
from simcore.geometry.voxelize import solid_voxels
from simcore.skeleton.section_centre import SECTION_LIMIT, centre_in_section


@pytest.fixture(scope="module")
def rod():
    """A capsule along X (axis y = z = 0, radius 0.2) and its voxel solid, 0.025 m voxels."""
    mesh = capsule_between(np.array([0.0, 0.0, 0.0]), np.array([2.0, 0.0, 0.0]), 0.2, count=32)
    return solid_voxels(mesh.vertices, mesh.faces, resolution=97)


def chain_along_x(offset: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Five joints x = 0.4 … 1.6 on a line shifted by `offset` (3,) from the rod's axis, and their parents."""
    x = np.linspace(0.4, 1.6, 5)
    return np.column_stack([x, np.zeros(5), np.zeros(5)]) + offset, np.arange(-1, 4)


def test_joints_a_fraction_of_a_voxel_off_the_axis_move_onto_it(rod):
    pos, parents = chain_along_x(np.array([0.0, 0.4, -0.3]) * rod.pitch)
    moved = centre_in_section(pos, parents, rod)
    before = np.linalg.norm(pos[1:, 1:], axis=1)
    after = np.linalg.norm(moved[1:, 1:], axis=1)
    assert np.all(after < 0.25 * before), (before / rod.pitch, after / rod.pitch)
    np.testing.assert_allclose(moved[:, 0], pos[:, 0], atol=1e-3 * rod.pitch)  # across the bone only
    np.testing.assert_array_equal(moved[0], pos[0])  # the root has no bone of its own: it stays


def test_a_joint_far_off_the_axis_moves_no_more_than_the_cap(rod):
    pos, parents = chain_along_x(np.array([0.0, 2.0, 0.0]) * rod.pitch)
    moved = centre_in_section(pos, parents, rod)
    step = np.linalg.norm(moved - pos, axis=1) / rod.pitch
    np.testing.assert_allclose(step[1:], SECTION_LIMIT, rtol=1e-6)
    assert np.all(moved[1:, 1] < pos[1:, 1])  # towards the axis


def test_a_junction_keeps_its_place(rod):
    pos, _ = chain_along_x(np.array([0.0, 0.4, 0.0]) * rod.pitch)
    parents = np.array([-1, 0, 1, 2, 2])  # joint 2 has two children
    moved = centre_in_section(pos, parents, rod)
    np.testing.assert_array_equal(moved[2], pos[2])
    assert abs(moved[3, 1]) < 0.25 * abs(pos[3, 1])
