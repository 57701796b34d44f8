"""Chains: where a junction-free skeleton is rooted, and the chain a flat sheet is rigged with."""

from __future__ import annotations

import numpy as np

from simcore.geometry.parts import SurfacePart, flat_normal, principal_frame

SHEET_PART_AREA = 0.01  # parts with less of the area (a button on a flag) do not decide whether it is a sheet


def chain_start(ends: np.ndarray, span: float) -> int:
    """Index into `ends` (N, 3), a chain's end joints, of the one it is rooted at: the lowest (+Y up), or the back
    (-Z) one among those within a tenth of `span` (the chain's length) of the lowest, when it lies level."""
    low = np.flatnonzero(ends[:, 1] < ends[:, 1].min() + 0.1 * (span or 1.0))
    return int(low[np.argmin(ends[low, 2])])


def segment_starts(points: np.ndarray) -> np.ndarray:
    """The joints of a chain whose segments run between consecutive `points` (K, 3): where each segment starts, in
    order from the end it is rooted at (`chain_start`), none on the far end (it would bend nothing). (K - 1, 3)."""
    span = float(np.ptp(points, axis=0).max())
    return (points if chain_start(points[[0, -1]], span) == 0 else points[::-1])[:-1]


def sheet_chain(parts: list[SurfacePart], ratio: float, spacing: float, max_joints: int) -> np.ndarray | None:
    """(J, 3) joints of a chain along the principal axis when the mesh is a flat sheet, else None.

    parts: the mesh's connected parts (surface_parts). A sheet (thickness < `ratio` × length) has no solid to
    thin; artists rig a strip, flag or card as one chain of even segments, max(`spacing`, sheet width) long, with
    a joint where each segment starts (the segment's pivot) and none on the far edge, which would bend nothing
    (a joint pulled back from the far edge instead would leave a stub last bone). Each part holding SHEET_PART_AREA of the
    area must be flat itself (two solids far apart are flat as a whole, and a chain through the empty space
    between them is no skeleton); the chain follows those parts, smaller ones (a button) take their weights from
    it.
    """
    total = sum(p.area for p in parts)
    deciding = [p.points for p in parts if p.area >= SHEET_PART_AREA * total] or [parts[0].points]
    if any(flat_normal(points, ratio) is None for points in deciding):
        return None
    pts = np.unique(np.concatenate(deciding), axis=0)
    centre, axes, local = principal_frame(pts)
    extent = np.ptp(local, axis=0)
    if extent[0] <= 0 or extent[2] >= ratio * extent[0]:
        return None
    segments = int(np.clip(np.floor(extent[0] / max(spacing, extent[1]) + 0.5), 2, max(max_joints, 2)))
    mid = 0.5 * (local.min(axis=0) + local.max(axis=0))
    t = local[:, 0].min() + extent[0] * np.arange(segments + 1) / segments
    chain = centre + (mid[None, :] * [0, 1, 1] + t[:, None] * [1, 0, 0]) @ axes
    return segment_starts(chain)
