"""Surface operators on triangle meshes: edge adjacency, cotangent Laplacian, lumped vertex areas."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from simcore.arrays import unique_ints

COT_MIN, COT_MAX = 1e-3, 1e3  # clamp: obtuse angles give negative cotangents; positive weights keep the maximum principle


def edges(faces: np.ndarray) -> np.ndarray:
    """(E, 2) int64 unique undirected edges (i < j) of triangles (F, 3)."""
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    e = np.sort(e, axis=1)
    e = e[e[:, 0] != e[:, 1]]
    n = int(e.max()) + 1 if len(e) else 1
    key = unique_ints(e[:, 0] * n + e[:, 1])  # 1-D keys: much faster than unique(axis=0)
    return np.stack([key // n, key % n], axis=1)


def adjacency(faces: np.ndarray, num_vertices: int) -> sp.csr_matrix:
    """(V, V) float64 symmetric 0/1 matrix of mesh edges."""
    e = edges(faces)
    a = sp.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(num_vertices, num_vertices))
    return (a + a.T).tocsr()


def cotangent_laplacian(vertices: np.ndarray, faces: np.ndarray) -> sp.csr_matrix:
    """(V, V) float64 symmetric negative semi-definite Laplacian L with L_ij = (cot a + cot b) / 2.

    vertices: (V, 3) float, faces: (F, 3) int (weld first: split vertices disconnect the surface).
    Cotangents are clamped to [COT_MIN, COT_MAX] so badly shaped and degenerate triangles cannot make
    weights negative or infinite; rows sum to zero.
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    n = len(v)
    rows, cols, vals = [], [], []
    for k in range(3):
        i, j, o = f[:, (k + 1) % 3], f[:, (k + 2) % 3], f[:, k]  # edge (i, j) opposite corner o
        a, b = v[i] - v[o], v[j] - v[o]
        cross = np.linalg.norm(np.cross(a, b), axis=1)
        cot = np.einsum("ij,ij->i", a, b) / np.maximum(cross, 1e-30)
        cot = np.clip(cot, COT_MIN, COT_MAX) * 0.5
        rows += [i, j]
        cols += [j, i]
        vals += [cot, cot]
    w = sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)).tocsr()
    return (w - sp.diags(np.asarray(w.sum(axis=1)).ravel())).tocsr()


def vertex_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(V,) float64 lumped (barycentric) area per vertex: a third of each incident triangle's area."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    area = 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
    return np.bincount(f.ravel(), weights=np.repeat(area / 3.0, 3), minlength=len(v))
