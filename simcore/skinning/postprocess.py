"""Weight post-processing shared by every skinning method: normalise, smooth along the surface, top-k."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

SMOOTH_ITERATIONS = 8  # default smoothing passes of every method's weights (JobOptions.smooth_iterations)


def normalize_rows(weights: np.ndarray) -> np.ndarray:
    """(V, J) float64 copy with non-negative rows summing to 1; all-zero rows stay zero."""
    w = np.maximum(np.asarray(weights, dtype=np.float64), 0.0)  # a copy, divided in place
    s = w.sum(axis=1, keepdims=True)
    return np.divide(w, s, out=w, where=s > 0)  # rows summing to 0 are already all zero


def smooth_on_surface(weights: np.ndarray, adjacency: sp.csr_matrix, iterations: int, strength: float = 0.5,
                      vertices: np.ndarray | None = None, reach: float = 0.0) -> np.ndarray:
    """Laplacian smoothing of per-vertex weights along mesh edges.

    weights: (V, J) float; adjacency: (V, V) 0/1 CSR (simcore.geometry.laplacian.adjacency). Each pass moves a
    vertex's weights `strength` of the way to the mean of its neighbours; isolated vertices keep theirs.
    With `vertices` (V, 3) and `reach` > 0, a neighbour farther than `reach` counts by (reach / length)²: the
    smoothing evens out steps at the scale of `reach` and does not carry weight along edges much longer than that
    (a coarse mesh's long edges would move weight across whole bones). Row sums are preserved (each pass is a
    convex combination of normalised rows).
    """
    w = np.array(weights, dtype=np.float64)  # a copy: the passes below update it in place
    if iterations <= 0 or adjacency.nnz == 0:
        return w
    degree = np.asarray(adjacency.sum(axis=1)).ravel()
    links = adjacency.tocoo()
    if vertices is not None and reach > 0:
        length = np.linalg.norm(vertices[links.row] - vertices[links.col], axis=1)
        share = np.minimum(1.0, (reach / np.maximum(length, 1e-30)) ** 2)
        links = sp.coo_matrix((links.data * share, (links.row, links.col)), shape=adjacency.shape)
    mean_op = (sp.diags(strength / np.maximum(degree, 1)) @ links).tocsr()  # strength × the mean (isolated rows: 0)
    keep = 1.0 - np.asarray(mean_op.sum(axis=1))  # what stays of each vertex's own weights
    for _ in range(iterations):
        moved = mean_op @ w
        w *= keep
        w += moved
    return w


def top_k(weights: np.ndarray, k: int, min_weight: float = 1e-4) -> sp.csr_matrix:
    """(V, J) float32 CSR keeping each row's k largest weights (≥ min_weight of the row), renormalised to 1.

    weights: (V, J) float, non-negative. A row whose weights are all zero stays empty (an unweighted vertex).
    """
    w = normalize_rows(weights)
    v, j = w.shape
    k = min(k, j)
    idx = np.argpartition(-w, k - 1, axis=1)[:, :k] if k < j else np.tile(np.arange(j), (v, 1))
    vals = np.take_along_axis(w, idx, axis=1)
    vals = np.where(vals >= min_weight, vals, 0.0)
    s = vals.sum(axis=1, keepdims=True)
    vals = np.divide(vals, s, out=np.zeros_like(vals), where=s > 0)
    rows = np.repeat(np.arange(v), k)
    out = sp.csr_matrix((vals.ravel(), (rows, idx.ravel())), shape=(v, j))
    out.eliminate_zeros()
    out.sort_indices()
    return out.astype(np.float32)


def bind_to_joint(weights: sp.csr_matrix, rows: np.ndarray, joint: int) -> sp.csr_matrix:
    """(V, J) CSR copy of `weights` in which the vertices `rows` follow `joint` alone (weight 1)."""
    if len(rows) == 0:
        return weights
    keep = np.ones(weights.shape[0], bool)
    keep[rows] = False
    rigid = sp.csr_matrix((np.ones(len(rows), dtype=weights.dtype), (rows, np.full(len(rows), joint))), shape=weights.shape)
    out = (sp.diags(keep.astype(weights.dtype)) @ weights + rigid).tocsr()
    out.eliminate_zeros()  # the cleared rows' entries
    return out
