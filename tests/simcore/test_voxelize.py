"""Solid voxelisation: the surface voxels are those of the surface samples, and closed shells are filled."""

from __future__ import annotations

import numpy as np
import trimesh

from simcore.geometry.voxelize import solid_voxels, surface_samples
from tests.meshes import joined


def _mixed_mesh() -> tuple[np.ndarray, np.ndarray]:
    """A finely subdivided sphere (triangles well under half a voxel) beside a coarse box (triangles many voxels
    long), so both the corner-only and the lattice paths of the surface marking run."""
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.3)
    box = trimesh.creation.box(extents=(0.8, 0.5, 0.4))
    box.apply_translation((1.0, 0.1, 0.0))
    mesh = joined([sphere, box])
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


def test_surface_voxels_are_those_of_the_surface_samples() -> None:
    vertices, faces = _mixed_mesh()
    grid = solid_voxels(vertices, faces, resolution=48)
    ijk = grid.index_of(surface_samples(vertices, faces, 0.5 * grid.pitch))
    want = np.zeros_like(grid.surface)
    want[tuple(ijk.T)] = True
    np.testing.assert_array_equal(grid.surface, want)
    assert want.sum() > 1000  # both parts' shells, not a handful of corners


def test_a_closed_box_is_filled_and_its_outside_is_not() -> None:
    box = trimesh.creation.box(extents=(1.0, 0.6, 0.4))
    grid = solid_voxels(np.asarray(box.vertices), np.asarray(box.faces), resolution=40)
    assert grid.inside(np.array([[0.0, 0.0, 0.0], [0.4, 0.25, 0.15]])).all()
    assert not grid.inside(np.array([[0.0, 0.5, 0.0], [0.7, 0.0, 0.0]])).any()
    interior = grid.occupancy & ~grid.surface
    assert interior.sum() > 0.5 * grid.occupancy.sum()
