"""Keep predicted joints inside the solid: move outsiders to the nearest occupied voxel."""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from simcore.geometry.voxelize import VoxelGrid


def snap_inside(grid: VoxelGrid, points: np.ndarray) -> np.ndarray:
    """(N, 3) copy of `points` (N, 3) with those outside `grid`'s solid moved to the nearest occupied voxel centre."""
    out = np.array(points, dtype=np.float64, copy=True)
    outside = ~grid.inside(out)
    if outside.any():
        _, idx = ndimage.distance_transform_edt(~grid.occupancy, return_indices=True)
        ijk = np.clip(grid.index_of(out[outside]), 0, np.asarray(grid.occupancy.shape) - 1)
        nearest = idx[:, ijk[:, 0], ijk[:, 1], ijk[:, 2]].T
        out[outside] = grid.centers(nearest)
    return out
