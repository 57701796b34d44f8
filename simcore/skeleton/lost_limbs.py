"""Limbs that 3D thinning erased, found by how far the solid reaches beyond the medial balls, and restored.

Lee thinning can shrink a thick, short protrusion into the body it hangs off (a short head on a round
body, a stocky animal's head or tail): the part then gets no bone and follows the trunk rigidly. A solid
voxel's *excess* is its shortest distance through the solid to a medial voxel minus that voxel's radius:
at most 0 inside the medial balls, growing beyond them. A connected region of positive excess is a lost
limb when it reaches farther beyond the balls than LENGTH_RATIO × its own radius (an elongated protrusion)
and is at least MIN_RADIUS voxels thick. A shallow cap over a blob's end, where thinning legitimately stops
short, reaches only about twice its own depth, and the thin tips of ears and fingers are below MIN_RADIUS.
A lost limb's medial line is the deepest path from its far end back to the medial voxels, stopped a radius
short of the tip as thinning stops. Measured along the solid, not in a straight line, so a leg beside
another leg is not taken for part of it.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy.sparse.csgraph import dijkstra

from simcore.geometry.voxel_graph import voxel_graph
from simcore.geometry.voxel_paths import VoxelPaths

REGION_EXCESS = 1.5  # voxels beyond the medial balls where a region starts (voxel rounding stays below)
LENGTH_RATIO = 3.0  # a region reaching farther than this × its radius beyond the balls is a limb
MIN_RADIUS = 2.0  # voxels: thinner regions (ear and finger tips) are left to the tip handling


def lost_limb_tips(paths: VoxelPaths, depth: np.ndarray, medial: np.ndarray) -> np.ndarray:
    """The far ends of the lost limbs.

    paths: the solid's voxels (pitch 1, so distances are in voxels); depth: (n,) each voxel's distance to the
    outside, voxels; medial: (m,) voxel ids of the thinned voxels. Returns (k,) tip voxel ids.
    """
    top = float(depth.max())
    # One search from every medial voxel at once, started at top - radius so the result minus top is the excess.
    excess = paths.distances(np.zeros(len(medial), np.int64), medial, top - depth[medial], 1)[:, 0] - top
    beyond = np.isfinite(excess) & (excess > REGION_EXCESS)
    grid = np.zeros(paths.ids.shape, bool)
    grid[tuple(paths.ijk[beyond].T)] = True
    labels, count = ndimage.label(grid, structure=np.ones((3, 3, 3), bool))
    region = labels[tuple(paths.ijk.T)]
    order = np.argsort(region, kind="stable")
    starts = np.searchsorted(region[order], np.arange(1, count + 2))
    tips = []
    for members in (order[a:b] for a, b in zip(starts[:-1], starts[1:])):
        reach = float(excess[members].max())
        radius = float(depth[members[excess[members] > 0.5 * reach]].max())  # the outer half: the limb's own
        if radius >= MIN_RADIUS and reach > LENGTH_RATIO * radius:
            tips.append(int(members[np.argmax(excess[members])]))
    return np.asarray(tips, np.int64)


def restore_lost_limbs(occupancy: np.ndarray, thin: np.ndarray, depth: np.ndarray) -> tuple[np.ndarray, int]:
    """`thin` (X, Y, Z) bool with the medial lines of lost limbs added, and how many were restored.

    occupancy: the solid; thin: its thinned voxels; depth: (X, Y, Z) distance to the outside in voxels.
    """
    paths = VoxelPaths(occupancy, 1.0)
    medial = paths.ids[thin & occupancy]
    if len(medial) == 0:
        return thin, 0
    voxel_depth = depth[tuple(paths.ijk.T)]
    tips = lost_limb_tips(paths, voxel_depth, medial)
    if len(tips) == 0:
        return thin, 0
    graph = voxel_graph(paths.ijk, weight_scale=voxel_depth**2)  # deep voxels are cheap: the path stays centred
    _, predecessor, _ = dijkstra(graph, indices=medial, min_only=True, return_predecessors=True)
    out = thin.copy()
    for tip in tips.tolist():
        path = [tip]
        while predecessor[path[-1]] >= 0:  # a medial voxel (a source) has no predecessor
            path.append(int(predecessor[path[-1]]))
        points = paths.ijk[path].astype(np.float64)
        from_tip = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
        kept = np.asarray(path)[from_tip >= voxel_depth[path]]  # a radius short of the tip, as thinning ends
        out[tuple(paths.ijk[kept].T)] = True
    return out, len(tips)
