"""Separate parts that stick out of a model: a sword held up, a staff, a spear, a bow.

Voxelised with the body, a prop held above the head becomes the highest medial branch (read as the head) or a
third arm, and no biped is found. When the humanoid fit fails, the skeleton step tries again without each such
part; the prop is still skinned with the mesh, so it follows the bones nearest to it (the hand holding it).
"""

from __future__ import annotations

import numpy as np

from simcore.geometry.parts import surface_parts

PROTRUSION = 0.05  # × the model's size: how far a part must reach beyond all the others to be tried away
MAX_TRIES = 3


def protruding_parts(vertices: np.ndarray, faces: np.ndarray, limit: int = MAX_TRIES) -> list[np.ndarray]:
    """(F,) bool face masks of up to `limit` separate parts that reach beyond every other part, farthest first.

    vertices: (V, 3) float, faces: (F, 3) int. The part with the most area (the body) is never one.
    """
    parts = surface_parts(vertices, faces)
    if len(parts) < 2:
        return []
    lo = np.array([p.points.min(axis=0) for p in parts])
    hi = np.array([p.points.max(axis=0) for p in parts])
    size = float((hi.max(axis=0) - lo.min(axis=0)).max())
    beyond = np.maximum(hi - _others(hi, highest=True), _others(lo, highest=False) - lo).max(axis=1)  # (K,)
    reach = [(float(beyond[k]), k) for k in range(1, len(parts)) if beyond[k] > PROTRUSION * size]
    masks = []
    for _, k in sorted(reach, reverse=True)[:limit]:
        mask = np.zeros(len(np.asarray(faces).reshape(-1, 3)), bool)
        mask[parts[k].faces] = True
        masks.append(mask)
    return masks


def _others(values: np.ndarray, *, highest: bool) -> np.ndarray:
    """(K, 3): per row, the highest (or lowest) value of each column among all the other rows. K ≥ 2."""
    order = np.argsort(values, axis=0)
    first, second = (order[-1], order[-2]) if highest else (order[0], order[1])
    cols = np.arange(values.shape[1])
    out = np.broadcast_to(values[first, cols], values.shape).copy()
    for c in cols:
        out[first[c], c] = values[second[c], c]
    return out
