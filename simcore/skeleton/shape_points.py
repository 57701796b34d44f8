"""The learned skeleton model's view of a mesh: surface points with normals in the token frame.

Both training samples and inference read meshes through `shape_points`, so the model sees the same frame
(z-up model frame of `simcore.skeleton.tokenizer`, the mesh's bounding box in [-1, 1]^3) in both.
"""

from __future__ import annotations

import numpy as np

from simcore.skeleton.tokenizer import Normalization, SkeletonTokenizer


def surface_points(vertices: np.ndarray, faces: np.ndarray, count: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """`count` points drawn uniformly by area on the triangles, and their faces' unit normals.

    vertices (V, 3), faces (F, 3) → points (count, 3) float64, normals (count, 3) float64 (zero on degenerate faces).
    """
    tri = np.asarray(vertices, dtype=np.float64)[np.asarray(faces, dtype=np.int64)]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = np.linalg.norm(cross, axis=1)
    chance = area / area.sum() if area.sum() > 0 else np.full(len(tri), 1.0 / len(tri))
    face = rng.choice(len(tri), size=count, p=chance)
    u, v = rng.uniform(size=(2, count))
    flip = u + v > 1.0  # fold the square onto the triangle
    u, v = np.where(flip, 1.0 - u, u), np.where(flip, 1.0 - v, v)
    t = tri[face]
    points = t[:, 0] + u[:, None] * (t[:, 1] - t[:, 0]) + v[:, None] * (t[:, 2] - t[:, 0])
    normals = cross[face] / np.maximum(area[face], 1e-30)[:, None]
    return points, normals


def shape_points(vertices: np.ndarray, faces: np.ndarray, count: int, rng: np.random.Generator) -> tuple[np.ndarray, Normalization]:
    """(count, 6) float32 model-frame points and normals of the mesh, and the normalisation that maps its tokens
    back to the mesh's frame (bounding box centre, longest half-side)."""
    norm = Normalization.from_points(vertices)
    points, normals = surface_points(vertices, faces, count, rng)
    frame = SkeletonTokenizer.model_frame
    return np.concatenate([frame(norm.to_unit(points)), frame(normals)], axis=1).astype(np.float32), norm
