"""Statistics of a triangle mesh for report.json."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from simcore.arrays import unique_ints
from simcore.geometry.referenced import referenced_mesh


def welded_faces(vertices: np.ndarray, faces: np.ndarray, decimals: int = 6) -> tuple[np.ndarray, int]:
    """Faces re-indexed so coincident vertices (UV/normal seams) share one index; returns (faces, unique count)."""
    scale = max(float(np.ptp(vertices, axis=0).max()), 1e-12)
    keys = np.round(vertices / scale, decimals)
    _, inverse = np.unique(keys, axis=0, return_inverse=True)
    return inverse.reshape(-1)[faces], int(inverse.max()) + 1


def mesh_stats(vertices: np.ndarray, faces: np.ndarray) -> dict:
    """Counts, bounding box, watertightness and connected components (after welding seams), of the vertices
    the faces use; unreferenced vertices are only counted."""
    mesh = referenced_mesh(vertices, faces)
    welded, n = welded_faces(mesh.vertices, mesh.faces)
    edges = np.sort(welded[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    edges = edges[edges[:, 0] != edges[:, 1]]
    _, counts = np.unique(edges, axis=0, return_counts=True)
    graph = sp.coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    used = np.zeros(n, bool)
    used[welded.reshape(-1)] = True
    n_comp, labels = connected_components(graph, directed=False)
    lo, hi = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
    return {
        "vertices": int(len(vertices)), "faces": int(len(faces)), "welded_vertices": int(used.sum()),
        "unreferenced_vertices": int(mesh.count - len(mesh.ids)),
        "bbox_min": lo.round(6).tolist(), "bbox_max": hi.round(6).tolist(), "size": (hi - lo).round(6).tolist(),
        "watertight": bool(len(counts) > 0 and np.all(counts == 2)),
        "components": int(len(unique_ints(labels[used]))),
    }
