"""The reference baseline of the skeleton evaluation: plain scikit-image skeletonisation of the solid voxels.

Every skeleton voxel is a joint and every pair of 26-neighbouring skeleton voxels a bone. It has no
hierarchy and no joint placement at articulations, only a dense medial line, which is why chamfer
metrics alone flatter it (issue 3); it is reported beside the real methods so one run shows both.
"""

from __future__ import annotations

import numpy as np

from simcore.geometry.voxelize import solid_voxels

VOXEL_RESOLUTION = 64  # voxels along the longest side


def voxel_skeleton_graph(vertices: np.ndarray, faces: np.ndarray, resolution: int = VOXEL_RESOLUTION) -> tuple[np.ndarray, np.ndarray]:
    """Medial voxels of the mesh's solid and their adjacency.

    vertices: (V, 3) float64, faces: (F, 3) int64.
    Returns joints (N, 3) float64 voxel centres in the mesh frame and edges (E, 2) int64 index pairs.
    """
    from skimage.morphology import skeletonize  # scikit-image: only the evaluation needs it

    grid = solid_voxels(vertices, faces, resolution=resolution)
    medial = skeletonize(grid.occupancy)  # Lee's 3-D thinning for volumes
    ijk = np.argwhere(medial)
    if len(ijk) == 0:  # a solid thinner than a voxel: fall back to its occupied voxels
        ijk = np.argwhere(grid.occupancy)
    lookup = {tuple(v): k for k, v in enumerate(ijk.tolist())}
    offsets = [(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1) if (a, b, c) > (0, 0, 0)]
    edges = [(k, lookup[(i + a, j + b, m + c)]) for k, (i, j, m) in enumerate(ijk.tolist())
             for a, b, c in offsets if (i + a, j + b, m + c) in lookup]
    return grid.centers(ijk), np.asarray(edges, dtype=np.int64).reshape(-1, 2)
