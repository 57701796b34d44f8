"""A body's mirror plane: the axis-aligned plane across which it looks most like itself (left/right)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from simcore.geometry.voxelize import VoxelGrid


@dataclass(frozen=True)
class MirrorPlane:
    """The plane x[axis] = offset across which a body looks most like itself."""

    axis: int
    offset: float

    def reflect(self, points: np.ndarray) -> np.ndarray:
        """(N, 3) mirror images of `points` (N, 3)."""
        out = np.array(points, dtype=np.float64, copy=True)
        out[:, self.axis] = 2.0 * self.offset - out[:, self.axis]
        return out


def mirror_plane(points: np.ndarray) -> MirrorPlane:
    """The axis-aligned plane through the centroid of `points` (N, 3) that maps them closest onto themselves
    (least mean distance from each mirrored point to the nearest original)."""
    tree = cKDTree(points)
    centre = points.mean(axis=0)
    planes = [MirrorPlane(axis, float(centre[axis])) for axis in range(3)]
    return min(planes, key=lambda plane: float(tree.query(plane.reflect(points))[0].mean()))


def solid_mirror(grid: VoxelGrid, centre: np.ndarray) -> tuple[MirrorPlane, float]:
    """The axis-aligned plane through `centre` (3,) (the mesh's vertex centroid: exact for a mirrored mesh, and
    moved little by a small prop) that maps the most of `grid`'s solid onto itself, and that share (0..1) of solid
    voxels whose mirror image lies within a voxel of the solid (voxel centres need not mirror each other)."""
    centres = grid.centers(np.argwhere(grid.occupancy))
    near = replace(grid, occupancy=ndimage.binary_dilation(grid.occupancy))
    planes = [MirrorPlane(axis, float(centre[axis])) for axis in range(3)]
    shares = [float(near.inside(plane.reflect(centres)).mean()) for plane in planes]
    best = int(np.argmax(shares))
    return planes[best], shares[best]
