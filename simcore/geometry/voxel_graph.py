"""The 26-neighbour graph of a set of voxels, as a sparse matrix for scipy's graph routines."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

# The 13 "forward" offsets of the 26-neighbourhood: each undirected voxel pair is generated once.
_OFFSETS = np.array(
    [(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1) if (i, j, k) > (0, 0, 0)], dtype=np.int64
)


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
