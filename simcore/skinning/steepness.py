"""Weights no steeper across an edge than a bend can carry without crushing it.

When a joint turns by θ against its parent, an edge whose two ends hand a share Δ of their weight from one to the
other (half the L1 distance of their rows) and lie about r from that joint (the pivot) sees its ends move apart or
together by about Δ · 2 sin(θ/2) · r: its length changes by that over its own length. Steepness Δ · r / length
therefore bounds the share by which a bend stretches or crushes the edge. Artists spread a blend over more edges
where the mesh is coarse or the blend lies far from the pivot; a model trained on their weights does not see the
edges, and leaves a few edges near joints with most of a blend (the gate's edge-compression check and the stretch
bound of `rigforge eval motion` find them). The pivot of an edge is the deeper of the two joints trading the most
weight along it (a child turning against its parent turns about its own head).

Each pass moves both ends of every edge steeper than the cap towards each other, so that the edge alone would end
at the cap; an end on several such edges takes the mean of its moves (a convex combination: rows keep their sums
and stay non-negative). Only edges next to a vertex that moved are measured again, so the cost follows the blends,
not the mesh. The cap is chosen on corpus val (the README's Skinning section carries the sweep).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from simcore.geometry.laplacian import edges
from simcore.skeleton.types import Skeleton, tree_depths

STEEPNESS_CAP = 0.5  # Δ · r / length: a 90° bend then changes a lone edge's length by at most about 0.7 of it
SLACK = 0.05  # an edge within this share over the cap counts as done (the last bit of the approach is slow)
PASSES = 30
# Work: edge measurements over all passes, at most WORK_PER_EDGE per edge of the mesh and MAX_WORK in all (about
# 0.25 s on 2 cores). A blend too narrow by n edges needs about n² passes to spread, so on a dense mesh (a 50k-vertex
# character) the limit is partial: the first passes take the steepest edges down, the budget stops the rest.
WORK_PER_EDGE = 8
MAX_WORK = 300_000
CHUNK_ENTRIES = 1_000_000  # edges × joints measured at once: the differences stay within 8 MB


class EdgeSteepness:
    """Steepness of the edges a[i]–b[i] of a mesh for one skeleton (see the module docstring)."""

    def __init__(self, vertices: np.ndarray, a: np.ndarray, b: np.ndarray, skeleton: Skeleton):
        self.a, self.b = a, b
        self.middle = 0.5 * (vertices[a] + vertices[b])
        self.length = np.linalg.norm(vertices[a] - vertices[b], axis=1)
        self.joints = skeleton.positions
        self.depth = tree_depths(skeleton.parents)

    def of(self, weights: np.ndarray, edges: np.ndarray) -> np.ndarray:
        """(n,) steepness of the n listed edges (indices into a, b) under (V, J) `weights`."""
        out = np.empty(len(edges))
        chunk = max(1, CHUNK_ENTRIES // weights.shape[1])
        for start in range(0, len(edges), chunk):
            part = edges[start:start + chunk]
            diff = weights[self.b[part]] - weights[self.a[part]]
            gain, loss = diff.argmax(axis=1), diff.argmin(axis=1)
            pivot = np.where(self.depth[gain] >= self.depth[loss], gain, loss)
            r = np.linalg.norm(self.middle[part] - self.joints[pivot], axis=1)
            out[start:start + chunk] = 0.5 * np.abs(diff).sum(axis=1) * r / self.length[part]
        return out


def mesh_edges(faces: np.ndarray, vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(a, b) int64 the ends of each edge of the triangles (F, 3) once (`laplacian.edges`), zero-length edges left
    out."""
    a, b = edges(faces).T
    keep = np.any(vertices[a] != vertices[b], axis=1)
    return a[keep], b[keep]


def limit_steepness(weights: np.ndarray, faces: np.ndarray, vertices: np.ndarray, skeleton: Skeleton,
                    cap: float = STEEPNESS_CAP, passes: int = PASSES) -> np.ndarray:
    """(V, J) float64 copy of `weights` in which the edges of the triangles `faces` (F, 3) steeper than `cap` are
    relaxed towards it, `passes` times at most. vertices: (V, 3) in the skeleton's space."""
    w = np.array(weights, dtype=np.float64)
    a, b = mesh_edges(faces, vertices)
    steepness = EdgeSteepness(vertices, a, b, skeleton)
    look = np.arange(len(a))  # the edges to measure this pass
    budget = min(WORK_PER_EDGE * len(a), MAX_WORK)
    for _ in range(passes):
        if budget <= 0:
            break
        budget -= len(look)
        measured = steepness.of(w, look)
        over = measured > cap * (1.0 + SLACK)
        if not over.any():
            break
        bad = look[over]
        share = 0.5 * (1.0 - cap / measured[over])  # of the gap, each end's move: the edge alone would end at the cap
        rows, slot = np.unique(np.r_[a[bad], b[bad]], return_inverse=True)
        # each end takes the mean of the moves its steep edges ask for, summed chunk by chunk as a sparse product
        ends = sp.csr_matrix((np.r_[np.ones(len(bad)), -np.ones(len(bad))],
                              (slot, np.r_[np.arange(len(bad)), np.arange(len(bad))])), shape=(len(rows), len(bad)))
        delta = np.zeros((len(rows), w.shape[1]))
        chunk = max(1, CHUNK_ENTRIES // w.shape[1])
        for start in range(0, len(bad), chunk):
            part = slice(start, start + chunk)
            delta += ends[:, part] @ (share[part, None] * (w[b[bad[part]]] - w[a[bad[part]]]))
        w[rows] += delta / np.bincount(slot)[:, None]
        moved = np.zeros(len(w), dtype=bool)
        moved[rows] = True
        look = np.flatnonzero(moved[a] | moved[b])
    return w
