"""Seams of a mesh sequence: vertices that share a position in every frame (flat shading, UV seams).

Surface operators need such vertices linked, or the mesh reads as many loose pieces. They are linked by
extra triangles (each joins two coincident vertices and a face neighbour of the first), so every original
vertex keeps its index and Dem Bones, which takes triangles, sees one surface.
"""

from __future__ import annotations

import numpy as np


def seam_triangles(frames: np.ndarray, faces: np.ndarray, tolerance: float = 1e-6) -> np.ndarray:
    """(S, 3) int64 triangles linking vertices within `tolerance` (a share of the first frame's bounding-box
    diagonal) of each other in every frame. Vertices that meet at rest but part later stay apart.

    frames: (T, V, 3); faces: (F, 3) int.
    """
    faces = np.asarray(faces, dtype=np.int64)
    diag = float(np.linalg.norm(np.ptp(frames[0], axis=0))) or 1.0
    cells = np.round(frames.transpose(1, 0, 2).reshape(frames.shape[1], -1) / (tolerance * diag)).astype(np.int64)
    group = np.unique(cells, axis=0, return_inverse=True)[1].reshape(-1)
    order = np.argsort(group, kind="stable")
    same = group[order[1:]] == group[order[:-1]]
    a, b = order[:-1][same], order[1:][same]  # consecutive members of one group
    neighbour = np.full(frames.shape[1], -1, np.int64)
    for k in range(3):
        neighbour[faces[:, k]] = faces[:, (k + 1) % 3]
    c = neighbour[a]
    keep = (c >= 0) & (c != b)
    return np.stack([a[keep], b[keep], c[keep]], axis=1)
