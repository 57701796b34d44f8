"""Mirror-symmetric joints for mirror-symmetric meshes.

Artists' rigs of symmetric characters are symmetric (so poses and animations can be mirrored); voxel thinning
and template fitting are not quite: a knee lands a voxel lower on one side, a spine joint beside the mid-plane.
When the mesh is its own mirror image across an axis-aligned plane, joints are paired with their mirror twins
and each is averaged with its twin's mirror image; a joint that is its own twin goes onto the plane. Twins are
matched globally (one-to-one, least total cost), the cost of a pair being how far each joint's mirror image is
from the other plus the same for their parents, so a knee pairs with the other knee, not with a foot tip pulled
close to it. Topology is left as it is.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from simcore.geometry.voxelize import VoxelGrid
from simcore.skeleton.mirror import solid_mirror

SYMMETRIC_SOLID = 0.8  # this share of the solid has solid at its mirror image: a symmetric body
PAIR_DISTANCE = 0.08  # × size: joints are twins when their mirror images and their parents' are within this


def symmetrize(positions: np.ndarray, parents: np.ndarray, grid: VoxelGrid, vertices: np.ndarray
               ) -> tuple[np.ndarray, dict]:
    """(J, 3) `positions` (parent indices `parents`, root -1) made mirror-symmetric when the mesh (`vertices`
    (V, 3), its solid `grid`) is, and a report.

    Report: {"axis": "x"|"y"|"z", "pairs": mirror twins, "on_plane": joints put on the plane}, or {"axis": None}
    when the solid is not symmetric (a posed character, a prop held out to one side) and nothing moved.
    Measured on the dev rigs (auto): J2J 0.0343 → 0.0335, B2B 0.0175 → 0.0167.
    """
    pos = np.array(positions, dtype=np.float64, copy=True)
    plane, share = solid_mirror(grid, np.asarray(vertices, dtype=np.float64).mean(axis=0))
    if share < SYMMETRIC_SOLID:
        return pos, {"axis": None}
    scale = float(np.ptp(np.argwhere(grid.occupancy), axis=0).max() + 1) * grid.pitch  # the solid's size
    mirrored = plane.reflect(pos)
    own = np.arange(len(pos))
    up = np.where(np.asarray(parents) >= 0, parents, own)  # the root stands in for its own parent
    apart = np.linalg.norm(mirrored[:, None] - pos[None], axis=2)
    cost = apart + apart[up][:, up]
    _, twin = linear_sum_assignment(cost)  # rows in order: twin[j] is j's mirror twin
    paired = (cost[own, twin] <= 2.0 * PAIR_DISTANCE * scale) & (twin[twin] == own)
    pos[paired] = 0.5 * (pos[paired] + mirrored[twin[paired]])
    on_plane = paired & (twin == own)
    return pos, {"axis": "xyz"[plane.axis], "pairs": int(np.count_nonzero(paired & ~on_plane)) // 2,
                 "on_plane": int(np.count_nonzero(on_plane))}
