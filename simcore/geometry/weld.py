"""Welding coincident vertices: flat-shaded and UV-seamed meshes repeat a position once per face corner.

Surface algorithms (Laplacians, smoothing, geodesics) need one vertex per position to see the mesh as
connected; results computed on the welded mesh are mapped back with `WeldedMesh.index`, so vertices
that share a position always get identical values (no cracks along seams in the deformed mesh).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

KEY_BITS = 21  # cell index bits per axis packed into one int64 key; the default tolerance needs 20


@dataclass
class WeldedMesh:
    """A mesh with coincident vertices merged.

    vertices: (U, 3) float64 unique positions (the first original vertex of each group).
    faces:    (F', 3) int64 triangles into `vertices`; faces that collapsed to a line or point are dropped.
    index:    (V,) int64 welded vertex of each original vertex: `values_welded[index]` maps back.
    """

    vertices: np.ndarray
    faces: np.ndarray
    index: np.ndarray


def weld_vertices(vertices: np.ndarray, faces: np.ndarray, tolerance: float | None = None) -> WeldedMesh:
    """Merge vertices closer than about `tolerance` (default 1e-6 of the bounding-box diagonal).

    vertices: (V, 3) float, faces: (F, 3) int. Positions are snapped to a `tolerance` grid, so two points
    within tolerance can (rarely) land in neighbouring cells and stay apart; that is harmless for the
    surface operators that use this.
    """
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if len(v) == 0:
        return WeldedMesh(v, f, np.zeros(0, np.int64))
    if tolerance is None:
        tolerance = 1e-6 * max(float(np.linalg.norm(v.max(axis=0) - v.min(axis=0))), 1e-12)
    keys = np.round((v - v.min(axis=0)) / tolerance).astype(np.int64)
    if keys.max() < 1 << KEY_BITS:  # one int64 per cell: a 1-D unique is several times faster than rows'
        keys = (keys[:, 0] << 2 * KEY_BITS) | (keys[:, 1] << KEY_BITS) | keys[:, 2]
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    # Keep the welded vertices in the order of their first occurrence (stable, easier to debug).
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    index = rank[inverse]
    wf = index[f]
    keep = (wf[:, 0] != wf[:, 1]) & (wf[:, 1] != wf[:, 2]) & (wf[:, 0] != wf[:, 2])
    return WeldedMesh(v[first[order]], wf[keep], index)
