"""Connected surface parts of a triangle mesh (seams welded), with their areas."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from simcore.geometry.laplacian import adjacency
from simcore.geometry.weld import WeldedMesh, weld_vertices


@dataclass
class SurfacePart:
    """One connected part. points: (P, 3) float64 its welded vertex positions; faces: (K,) int64 indices of its
    triangles in the input faces; area: their total area."""

    points: np.ndarray
    faces: np.ndarray
    area: float


def part_labels(vertices: np.ndarray, faces: np.ndarray, tolerance: float | None = None) -> np.ndarray:
    """(V,) int64 connected-component label of each vertex of the surface welded within `tolerance` (default:
    `weld_vertices`'), so seam duplicates share one; a face's part is its first vertex's label."""
    welded = weld_vertices(vertices, faces, tolerance)
    return welded_part_labels(welded, adjacency(welded.faces, len(welded.vertices)))


def welded_part_labels(welded: WeldedMesh, adj: sp.spmatrix) -> np.ndarray:
    """`part_labels` from a weld and its vertex adjacency that the caller already has."""
    _, label = connected_components(adj, directed=False)
    return np.asarray(label, np.int64)[welded.index]


def surface_parts(vertices: np.ndarray, faces: np.ndarray) -> list[SurfacePart]:
    """The connected parts of a mesh, largest area first; parts touch through shared (welded) vertices.

    vertices: (V, 3) float, faces: (F, 3) int. A mesh whose triangles all collapsed is one part of zero area.
    """
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    welded = weld_vertices(vertices, f)
    if len(welded.faces) == 0:
        return [SurfacePart(np.asarray(vertices, dtype=np.float64).reshape(-1, 3), np.arange(len(f)), 0.0)]
    count, label = connected_components(adjacency(welded.faces, len(welded.vertices)), directed=False)
    face_label = label[welded.index[f[:, 0]]]
    tri = welded.vertices[welded.index[f]]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    part_area = np.bincount(face_label, weights=area, minlength=count)
    used = np.zeros(len(welded.vertices), bool)
    used[welded.faces.ravel()] = True
    points = _split(welded.vertices[used], label[used], count)  # one sort each, not a pass per part
    face_ids = _split(np.arange(len(f)), face_label, count)
    parts = [SurfacePart(points[k], face_ids[k], float(part_area[k])) for k in range(count)]
    return sorted((p for p in parts if len(p.points)), key=lambda p: -p.area)


def _split(values: np.ndarray, label: np.ndarray, count: int) -> list[np.ndarray]:
    """values grouped by their label in [0, count): one array per label, in the values' order."""
    order = np.argsort(label, kind="stable")
    return np.split(values[order], np.cumsum(np.bincount(label, minlength=count))[:-1])


def principal_frame(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(centre (3,), axes (3, 3) rows by decreasing spread, coordinates (N, 3) in that frame) of points (N, 3)."""
    centre = points.mean(axis=0)
    _, _, axes = np.linalg.svd(points - centre, full_matrices=False)
    if len(axes) < 3:
        axes = np.vstack([axes, np.eye(3)])[:3]
    return centre, axes, (points - centre) @ axes.T


def flat_normal(points: np.ndarray, ratio: float) -> np.ndarray | None:
    """(3,) unit normal of points thinner than `ratio` × their length along their principal axes, else None."""
    _, axes, local = principal_frame(points)
    extent = np.ptp(local, axis=0)
    return axes[2] if extent[0] > 0 and extent[2] < ratio * extent[0] else None


def bulk_size(parts: list[SurfacePart], share: float = 0.9) -> float:
    """Longest bounding-box side of the largest parts that together hold `share` of the area: a small part far
    away (a prop left across the scene) does not set the size. parts: surface_parts' list, largest first."""
    total = sum(p.area for p in parts)
    held, points = 0.0, []
    for part in parts:
        points.append(part.points)
        held += part.area
        if held >= share * total:
            break
    return float(np.ptp(np.concatenate(points), axis=0).max())
