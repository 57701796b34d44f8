"""Measures on deforming meshes used by the refine report and the inverse fit: volume, chamfer distance."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from simcore.geometry.parts import part_labels


def vertex_parts(vertices: np.ndarray, faces: np.ndarray, weld: float = 1e-6) -> np.ndarray:
    """(V,) int64 part of each vertex: connected components of the surface with vertices closer than `weld` × the
    mesh size merged first (seams that split vertices do not split a part)."""
    v = np.asarray(vertices, np.float64)
    size = float(np.ptp(v, axis=0).max()) if len(v) else 1.0
    return part_labels(v, np.asarray(faces, np.int64).reshape(-1, 3), weld * (size or 1.0))


def volume_parts(vertices: np.ndarray, faces: np.ndarray, weld: float = 1e-6) -> np.ndarray:
    """(F,) int64 part of each face (`vertex_parts` of its first corner)."""
    faces = np.asarray(faces, np.int64)
    if len(faces) == 0:
        return np.zeros(0, np.int64)
    return vertex_parts(vertices, faces, weld)[faces[:, 0]]


def part_centres(vertices: np.ndarray, faces: np.ndarray, face_parts: np.ndarray) -> np.ndarray:
    """(P, 3) each part's centre, the mean of its faces' corners, of one frame's vertices (V, 3)."""
    parts = int(face_parts.max()) + 1 if len(face_parts) else 0
    corner_parts = np.repeat(face_parts, 3)
    counts = np.bincount(corner_parts, minlength=parts).astype(np.float64)
    corners = np.asarray(vertices, np.float64)[np.asarray(faces, np.int64).reshape(-1)]  # (3F, 3)
    sums = np.stack([np.bincount(corner_parts, corners[:, k], minlength=parts) for k in range(3)], 1)
    return sums / np.maximum(counts, 1.0)[:, None]


def part_volumes(frames: np.ndarray, faces: np.ndarray, face_parts: np.ndarray) -> np.ndarray:
    """(T, P) signed volume of each part's triangles as cones from that part's vertex centroid in the same frame.

    For a closed part this is its enclosed volume; for an open one it depends on the apex, and with the part's own
    centroid as apex it is unchanged by any rigid motion of the part, so its ratio to the rest value measures
    deformation alone (the origin-referenced sum of a whole open or multi-part mesh changes as parts move).
    """
    f = np.asarray(frames, dtype=np.float64)
    f = f[None] if f.ndim == 2 else f
    faces = np.asarray(faces, np.int64)
    parts = int(face_parts.max()) + 1 if len(face_parts) else 0
    out = np.zeros((len(f), parts))
    for t in range(len(f)):
        apex = part_centres(f[t], faces, face_parts)[face_parts]
        a, b, c = (f[t][faces[:, k]] - apex for k in range(3))
        triple = np.einsum("fi,fi->f", a, np.cross(b, c))
        out[t] = np.bincount(face_parts, triple, minlength=parts) / 6.0
    return out


def volume_change(parts: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """(T,) volume-weighted mean of each part's |V_p(t) / V_p(rest) − 1| from part volumes (T, P) and rest (P,):
    opposite changes of different parts do not cancel; a single closed part gives |V(t) / V(rest) − 1|."""
    weight = np.abs(rest)
    total = float(weight.sum())
    if total <= 0.0:
        return np.zeros(len(parts))
    safe = np.where(weight > 0, rest, 1.0)
    return (np.abs(parts / safe[None] - 1.0) * weight[None]).sum(axis=1) / total


def chamfer(a: np.ndarray, b: np.ndarray) -> float:
    """Symmetric chamfer distance: mean nearest-neighbour distance a→b plus b→a, halved. a: (N, 3), b: (M, 3)."""
    return 0.5 * float(cKDTree(b).query(a)[0].mean() + cKDTree(a).query(b)[0].mean())


def chamfer_grad(a: np.ndarray, b: np.ndarray) -> tuple[float, np.ndarray]:
    """Squared chamfer L = mean_a |a − nn_b(a)|² + mean_b |b − nn_a(b)|² and dL/da (N, 3) float64."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    _, ia = cKDTree(b).query(a)
    _, ib = cKDTree(a).query(b)
    da = a - b[ia]
    db = b - a[ib]
    loss = float((da**2).sum(axis=1).mean() + (db**2).sum(axis=1).mean())
    grad = 2.0 * da / len(a)
    np.add.at(grad, ib, -2.0 * db / len(b))
    return loss, grad
