"""A body's mirror plane: the axis-aligned plane across which it looks most like itself (left/right)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

MAX_QUERIES = 5_000  # mirrored points looked up (every k-th): enough to judge a plane, fast on 100k vertices


@dataclass(frozen=True)
class MirrorPlane:
    """The plane x[axis] = offset across which a body looks most like itself."""

    axis: int
    offset: float

    def reflect(self, points: np.ndarray) -> np.ndarray:
        """(N, 3) mirror images of `points` (N, 3)."""
        out = np.array(points, dtype=np.float64, copy=True)
        out[:, self.axis] = 2.0 * self.offset - out[:, self.axis]
        return out


def best_mirror(points: np.ndarray) -> tuple[MirrorPlane, float]:
    """The axis-aligned plane through the centroid of `points` (N, 3) that maps them closest onto themselves, and
    how close: the mean distance from a mirrored point to the nearest original (0 for an exact mirror image)."""
    pts = np.asarray(points, dtype=np.float64)
    tree = cKDTree(pts)
    queries = pts[:: max(1, len(pts) // MAX_QUERIES)]
    centre = pts.mean(axis=0)
    planes = [MirrorPlane(axis, float(centre[axis])) for axis in range(3)]
    spreads = [float(tree.query(plane.reflect(queries))[0].mean()) for plane in planes]
    best = int(np.argmin(spreads))
    return planes[best], spreads[best]


def mirror_plane(points: np.ndarray) -> MirrorPlane:
    """The plane of `best_mirror`."""
    return best_mirror(points)[0]
