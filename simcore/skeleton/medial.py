"""Medial skeleton of a voxelised solid: 3D thinning → voxel graph → a spanning forest that keeps thick parts.

Thinning is scikit-image's 3D `skeletonize` (Lee et al. 1994 medial-axis thinning). Unlike a
distance-transform ridge it gives one-voxel-wide, connected curves with no surface
sheets, which is what the graph steps need; the Euclidean distance transform supplies each medial voxel's
radius (local half-thickness), used to judge spurs, junction merges and where loops should be cut.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.sparse.csgraph import connected_components, minimum_spanning_tree

from simcore.geometry.voxel_graph import voxel_graph
from simcore.geometry.voxelize import VoxelGrid
from simcore.skeleton.lost_limbs import restore_lost_limbs


@dataclass
class MedialForest:
    """Medial voxels joined into trees (one per connected medial curve set).

    positions: (N, 3) float64 world centres of the medial voxels, metres.
    radius:    (N,) float64 distance from each medial voxel to the outside, metres.
    adjacency: N lists of neighbour node ids; the graph is a forest (no cycles).
    component: (N,) int64 connected-component label of each node.
    restored:  how many limbs that thinning erased were restored (simcore.skeleton.lost_limbs).
    """

    positions: np.ndarray
    radius: np.ndarray
    adjacency: list[list[int]]
    component: np.ndarray
    restored: int = 0


def medial_voxels(grid: VoxelGrid, restore_limbs: bool = False) -> tuple[np.ndarray, np.ndarray, int]:
    """Thin the grid's occupancy; with `restore_limbs`, limbs that thinning erased get their medial line back.

    Returns ((N, 3) int64 voxel indices in C order, (N,) float64 radius in metres, limbs restored).
    """
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
    restored = 0
    if restore_limbs:
        thin, restored = restore_lost_limbs(occupancy, thin, dist)
    ijk = np.argwhere(thin).astype(np.int64)
    return ijk, dist[tuple(ijk.T)] * grid.pitch, restored


def medial_forest(grid: VoxelGrid, restore_limbs: bool = False) -> MedialForest:
    """Thin `grid` (see medial_voxels), join medial voxels, and cut cycles at their thinnest edge (maximum
    spanning tree on radius)."""
    ijk, radius, restored = medial_voxels(grid, restore_limbs)
    graph = voxel_graph(ijk, weight_scale=radius)
    tree = minimum_spanning_tree(graph)  # weight = length / radius: loops break where the solid is thinnest
    tree = (tree + tree.T).tocoo()
    adjacency: list[list[int]] = [[] for _ in range(len(ijk))]
    for a, b in sorted(zip(tree.row.tolist(), tree.col.tolist())):
        adjacency[a].append(b)
    _, component = connected_components(tree, directed=False)
    return MedialForest(grid.centers(ijk), radius, adjacency, component.astype(np.int64), restored)
