"""Connected surface parts of a triangle mesh (seams welded), with their areas."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse.csgraph import connected_components

from simcore.geometry.laplacian import adjacency
from simcore.geometry.weld import weld_vertices


@dataclass
class SurfacePart:
    """points: (P, 3) float64 welded vertex positions of one connected part; area: its triangle area."""

    points: np.ndarray
    area: float


def surface_parts(vertices: np.ndarray, faces: np.ndarray) -> list[SurfacePart]:
    """The connected parts of a mesh, largest area first; parts touch through shared (welded) vertices.

    vertices: (V, 3) float, faces: (F, 3) int. A mesh whose triangles all collapsed is one part of zero area.
    """
    welded = weld_vertices(vertices, faces)
    if len(welded.faces) == 0:
        return [SurfacePart(np.asarray(vertices, dtype=np.float64).reshape(-1, 3), 0.0)]
    count, label = connected_components(adjacency(welded.faces, len(welded.vertices)), directed=False)
    tri = welded.vertices[welded.faces]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    part_area = np.bincount(label[welded.faces[:, 0]], weights=area, minlength=count)
    used = np.zeros(len(welded.vertices), bool)
    used[welded.faces.ravel()] = True
    parts = [SurfacePart(welded.vertices[(label == k) & used], float(part_area[k])) for k in range(count)]
    return sorted((p for p in parts if len(p.points)), key=lambda p: -p.area)
