"""Skinning large meshes on a simplified proxy, so a job's memory does not grow with the vertex count.

Above PROXY_VERTICES the surface is simplified (quadric error decimation by the fast-simplification library)
to about PROXY_TARGET vertices; the methods run on the proxy and each full-resolution vertex takes the
inverse-distance blend of its NEIGHBOURS nearest proxy vertices' weights, chunk by chunk, as a sparse matrix.
"""

from __future__ import annotations

import fast_simplification
import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from simcore.skinning.postprocess import top_k

PROXY_VERTICES = 150_000
PROXY_TARGET = 80_000
NEIGHBOURS = 4
CHUNK = 200_000  # full-resolution vertices transferred at a time


def simplified(vertices: np.ndarray, faces: np.ndarray, target: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(vertices, faces) of the mesh decimated to about `target` (default PROXY_TARGET) vertices."""
    reduction = 1.0 - (target or PROXY_TARGET) / len(vertices)
    v, f = fast_simplification.simplify(np.asarray(vertices, np.float32), np.asarray(faces, np.int32), target_reduction=reduction)
    return np.asarray(v, np.float64), np.asarray(f, np.int64)


def transfer(weights: sp.csr_matrix, proxy: np.ndarray, vertices: np.ndarray, max_influences: int,
             neighbours: int = NEIGHBOURS) -> sp.csr_matrix:
    """(V, J) float32 CSR weights of `vertices` from the proxy's (P, J) weights: inverse-distance blend of the
    `neighbours` nearest proxy vertices, then the `max_influences` largest kept."""
    tree = cKDTree(proxy)
    k = min(neighbours, len(proxy))
    blocks = []
    for start in range(0, len(vertices), CHUNK):
        dist, idx = tree.query(vertices[start:start + CHUNK], k=k)
        dist, idx = dist.reshape(len(idx), k), idx.reshape(len(idx), k)
        inv = 1.0 / np.maximum(dist, 1e-12)
        share = inv / inv.sum(axis=1, keepdims=True)
        rows = np.repeat(np.arange(len(idx)), k)
        blend = sp.csr_matrix((share.ravel(), (rows, idx.ravel())), shape=(len(idx), len(proxy)))
        blocks.append(top_k((blend @ weights).toarray(), max_influences))
    return sp.vstack(blocks).tocsr()
