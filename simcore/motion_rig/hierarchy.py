"""A joint tree over free bones: a spanning tree of the bones that move as joints, a root, joint positions."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import minimum_spanning_tree, shortest_path

from simcore.motion_rig.joints import BonePairs


@dataclass
class BoneTree:
    """Bones in parents-first order.

    order:     (B,) int64 free-bone index of each tree bone (tree bone i is free bone order[i]).
    parents:   (B,) int64 parent tree index, -1 for the root (index 0).
    joints:    (B, 3) float64 rest-pose joint of each bone with its parent (the root's: its vertices' centre).
    floating:  (B,) bool bones whose joint moves freely (an animated offset from the parent): the root, bones of a
               mesh part that touches no other bone (hung from the nearest bone, at their own centre), and bones
               whose motion has no pivot with their parent's (`sliding`: the joint at the centre of their border,
               since the best point of a pair that turns about none can lie far off).
    borders:   (B, 3) float64 centre of each bone's border with its parent (the root's, a separate part's: its
               vertices' centre): a point inside the surface near the joint.
    stiffness: (B, 3, 3) float64 the pair's `BonePairs.stiffness` with the parent (zero where there is no pair).
    """

    order: np.ndarray
    parents: np.ndarray
    joints: np.ndarray
    floating: np.ndarray
    sliding: np.ndarray
    borders: np.ndarray
    stiffness: np.ndarray


def bone_tree(rest: np.ndarray, weights: np.ndarray, pairs: BonePairs, slide: float) -> BoneTree:
    """Spanning tree of least joint mismatch over touching bones, rooted at the tree's centre.

    rest: (V, 3); weights: (V, B). Bones in separate parts of the mesh (no touching pair links them) are joined
    to the nearest bone of the rest, with the joint at their own centre. slide: a pair mismatch (metres) past
    which the two bones do not turn about one point (a surface that bends or stretches there), so the child's
    joint slides too.
    """
    count = weights.shape[1]
    mass = weights.sum(axis=0)
    centres = (weights.T @ rest) / np.maximum(mass, 1e-12)[:, None]
    spacing = np.linalg.norm(centres[:, None] - centres[None], axis=-1)
    cost = np.zeros((count, count))
    a, b = pairs.pairs.T
    touching = np.zeros((count, count), bool)
    touching[a, b] = touching[b, a] = True
    join = pairs.mismatch + 1e-9 * (1.0 + spacing[a, b])  # a zero cost would read as "no edge"
    cost[a, b] = cost[b, a] = join
    ceiling = (join.max() if len(join) else 0.0) + spacing.max() + 1.0  # bridges only where nothing touches
    bridge = ~touching & ~np.eye(count, dtype=bool)
    cost[bridge] = ceiling + spacing[bridge]
    tree = minimum_spanning_tree(sp.csr_matrix(cost))  # sparse: a dense graph reads costs near 0 as no edge
    tree = tree + tree.T
    edges = tree.tocoo()
    lengths = tree.copy()
    lengths.data = spacing[edges.row, edges.col] + 1e-12
    far = shortest_path(lengths, directed=False).max(axis=1)
    root = int(np.lexsort((-mass, far))[0])  # the centre of the tree; the heavier bone on a tie
    order, parent_of = [root], {root: -1}
    neighbours = [tree.indices[tree.indptr[i]:tree.indptr[i + 1]] for i in range(count)]
    for bone in order:  # breadth first: parents come first
        for nxt in neighbours[bone].tolist():
            if nxt not in parent_of:
                parent_of[nxt] = bone
                order.append(nxt)
    index = {bone: i for i, bone in enumerate(order)}
    pivot_of = {(int(x), int(y)): p for (x, y), p, m in zip(pairs.pairs, pairs.pivots, pairs.mismatch) if m <= slide}
    best = {(int(x), int(y)): p for (x, y), p in zip(pairs.pairs, pairs.pivots)}
    border = {(int(x), int(y)): c for (x, y), c in zip(pairs.pairs, pairs.borders)}
    firm = {(int(x), int(y)): k for (x, y), k in zip(pairs.pairs, pairs.stiffness)}
    joints, borders, stiffness = np.empty((count, 3)), np.empty((count, 3)), np.zeros((count, 3, 3))
    floating, sliding = np.zeros(count, bool), np.zeros(count, bool)
    for i, bone in enumerate(order):
        up = parent_of[bone]
        key = (min(up, bone), max(up, bone))
        floating[i] = key not in pivot_of
        sliding[i] = up >= 0 and key in best and key not in pivot_of
        joints[i] = pivot_of.get(key, border.get(key, centres[bone]))  # a free joint's place changes no fit
        borders[i] = border.get(key, centres[bone])
        stiffness[i] = firm.get(key, np.zeros((3, 3)))
    parents = np.array([index[parent_of[bone]] if parent_of[bone] >= 0 else -1 for bone in order], np.int64)
    return BoneTree(np.asarray(order, np.int64), parents, joints, floating, sliding, borders, stiffness)
