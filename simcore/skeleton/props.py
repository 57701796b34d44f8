"""Separate parts that can keep a humanoid from being found: props that stick out of the model (a sword held
up, a staff, a spear) and a big shell over the body (a skirt, a coat).

Voxelised with the body, a prop held above the head becomes the highest medial branch (read as the head) or a
third arm, and a skirt's shell adds branches of its own. When the humanoid fit fails, the skeleton step tries
again without such parts; they are still skinned with the mesh, so they follow the bones nearest to them.
"""

from __future__ import annotations

import numpy as np

from simcore.geometry.parts import SurfacePart

PROTRUSION = 0.05  # × the model's size: how far a part must reach beyond all the others to be tried away
SHELL_SHARE = 0.5  # the part with the most area is tried away when the others hold at least this share
MAX_SINGLE = 3  # parts tried one at a time; then all of them at once
MAX_LEFT_OUT = 0.4  # share of the area: a bigger part (a second character beside the first) is never left out


def parts_to_try_without(parts: list[SurfacePart], face_count: int) -> list[np.ndarray]:
    """(F,) bool face masks to fit again without, in order: up to MAX_SINGLE single parts (the largest part
    when the others hold SHELL_SHARE of the area, so it may be a shell over them; then those reaching beyond
    every other part, farthest first), then their union when there are several; never more than MAX_LEFT_OUT
    of the area.
    parts: the mesh's connected parts (surface_parts) over its `face_count` triangles."""
    if len(parts) < 2:
        return []
    lo = np.array([p.points.min(axis=0) for p in parts])
    hi = np.array([p.points.max(axis=0) for p in parts])
    size = float((hi.max(axis=0) - lo.min(axis=0)).max())
    beyond = np.maximum(hi - _others(hi, highest=True), _others(lo, highest=False) - lo).max(axis=1)  # (K,)
    area = np.array([p.area for p in parts]) / max(sum(p.area for p in parts), 1e-30)
    chosen = [0] if area[1:].sum() >= SHELL_SHARE else []
    chosen += [k for _, k in sorted((-beyond[k], k) for k in range(1, len(parts)) if beyond[k] > PROTRUSION * size)]
    chosen = [k for k in chosen if area[k] <= MAX_LEFT_OUT][:MAX_SINGLE]
    masks = []
    for k in chosen:
        mask = np.zeros(face_count, bool)
        mask[parts[k].faces] = True
        masks.append(mask)
    union = [np.logical_or.reduce(masks)] if len(masks) > 1 and area[chosen].sum() <= MAX_LEFT_OUT else []
    return masks + union


def _others(values: np.ndarray, *, highest: bool) -> np.ndarray:
    """(K, 3): per row, the highest (or lowest) value of each column among all the other rows. K ≥ 2."""
    order = np.argsort(values, axis=0)
    first, second = (order[-1], order[-2]) if highest else (order[0], order[1])
    cols = np.arange(values.shape[1])
    out = np.broadcast_to(values[first, cols], values.shape).copy()
    for c in cols:
        out[first[c], c] = values[second[c], c]
    return out
