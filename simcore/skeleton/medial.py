"""Medial skeleton of a voxelised solid: 3D thinning → voxel graph → a spanning forest that keeps thick parts.

Thinning is scikit-image's 3D `skeletonize` (Lee et al. 1994 medial-axis thinning). Measured against a
distance-transform ridge on the dev assets it gives one-voxel-wide, connected curves with no surface
sheets, which is what the graph steps need; the Euclidean distance transform supplies each medial voxel's
radius (local half-thickness), used to judge spurs, junction merges and where loops should be cut.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy import ndimage
from scipy.sparse.csgraph import connected_components, minimum_spanning_tree

from simcore.geometry.voxelize import VoxelGrid

# The 13 "forward" offsets of the 26-neighbourhood: each undirected voxel pair is generated once.
_OFFSETS = np.array(
    [(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1) if (i, j, k) > (0, 0, 0)], dtype=np.int64
)


@dataclass
class MedialForest:
    """Medial voxels joined into trees (one per connected medial curve set).

    positions: (N, 3) float64 world centres of the medial voxels, metres.
    radius:    (N,) float64 distance from each medial voxel to the outside, metres.
    adjacency: N lists of neighbour node ids; the graph is a forest (no cycles).
    component: (N,) int64 connected-component label of each node.
    """

    positions: np.ndarray
    radius: np.ndarray
    adjacency: list[list[int]]
    component: np.ndarray


def medial_voxels(grid: VoxelGrid) -> tuple[np.ndarray, np.ndarray]:
    """Thin the grid's occupancy. Returns ((N, 3) int64 voxel indices in C order, (N,) float64 radius, metres)."""
    from skimage.morphology import skeletonize

    occupancy = grid.occupancy
    thin = skeletonize(occupancy).astype(bool)
    labels, count = ndimage.label(occupancy, structure=np.ones((3, 3, 3), bool))
    dist = ndimage.distance_transform_edt(occupancy)
    if count:
        lost = np.setdiff1d(np.arange(1, count + 1), np.unique(labels[thin]))
        if len(lost):
            # Lee thinning can erase a box of even voxel width entirely; peeling one voxel layer off one side
            # of each axis flips the width parity, and that thinning is used for the bodies that vanished.
            peeled = occupancy.copy()
            peeled[1:, 1:, 1:] &= occupancy[:-1, :-1, :-1]
            retry = skeletonize(peeled).astype(bool)
            thin |= retry & np.isin(labels, lost)
        # A solid thinner than one voxel can still vanish; keep its deepest voxel so every body has a node.
        for lab in np.setdiff1d(np.arange(1, count + 1), np.unique(labels[thin])):
            idx = ndimage.maximum_position(dist, labels, lab)
            thin[idx] = True
    ijk = np.argwhere(thin).astype(np.int64)
    return ijk, dist[tuple(ijk.T)] * grid.pitch


def voxel_graph(ijk: np.ndarray, weight_scale: np.ndarray | None = None) -> sp.csr_matrix:
    """Symmetric (N, N) sparse graph joining 26-neighbouring voxels; edge weight = Euclidean voxel distance,
    divided by the mean of `weight_scale` (N,) at its ends when given (so thick edges are cheap)."""
    n = len(ijk)
    dims = ijk.max(axis=0) + 3 if n else np.ones(3, np.int64)
    key = ((ijk[:, 0] + 1) * dims[1] + ijk[:, 1] + 1) * dims[2] + ijk[:, 2] + 1  # +1 keeps neighbours non-negative
    order = np.argsort(key)
    sorted_key = key[order]
    rows, cols, vals = [], [], []
    for off in _OFFSETS:
        nkey = ((ijk[:, 0] + 1 + off[0]) * dims[1] + ijk[:, 1] + 1 + off[1]) * dims[2] + ijk[:, 2] + 1 + off[2]
        pos = np.clip(np.searchsorted(sorted_key, nkey), 0, max(n - 1, 0))
        found = sorted_key[pos] == nkey if n else np.zeros(0, bool)
        a = np.flatnonzero(found)
        b = order[pos[found]]
        length = float(np.linalg.norm(off))
        w = np.full(len(a), length)
        if weight_scale is not None:
            w = w / np.maximum(0.5 * (weight_scale[a] + weight_scale[b]), 1e-12)
        rows.append(a)
        cols.append(b)
        vals.append(w)
    r, c, v = (np.concatenate(x) if x else np.zeros(0) for x in (rows, cols, vals))
    g = sp.coo_matrix((v, (r, c)), shape=(n, n)).tocsr()
    return (g + g.T).tocsr()


def medial_forest(grid: VoxelGrid) -> MedialForest:
    """Thin `grid`, join medial voxels, and cut cycles at their thinnest edge (maximum spanning tree on radius)."""
    ijk, radius = medial_voxels(grid)
    graph = voxel_graph(ijk, weight_scale=radius)
    tree = minimum_spanning_tree(graph)  # weight = length / radius: loops break where the solid is thinnest
    tree = (tree + tree.T).tocoo()
    adjacency: list[list[int]] = [[] for _ in range(len(ijk))]
    for a, b in sorted(zip(tree.row.tolist(), tree.col.tolist())):
        adjacency[a].append(b)
    _, component = connected_components(tree, directed=False)
    return MedialForest(grid.centers(ijk), radius, adjacency, component.astype(np.int64))
