"""Edge loops of a low-poly tube: the cross-section rings where its mesh can bend.

A low-poly mesh deforms only at its vertices. A tube modelled as a few rings of vertices (a rope, a tentacle, a
pole) can bend only at those rings, so riggers put a joint at each ring, the pivot of the segment above it, and
none at the far end, which would bend nothing (a tube of three rings gets joints at its base and middle).
Placing joints on the rings matches where such a mesh can actually deform, which an evenly spaced medial chain
does not; organic, densely tessellated meshes have no such sparse rings, so the rule leaves them alone.
"""

from __future__ import annotations

import numpy as np

from simcore.geometry.parts import principal_frame

LOOP_TOL = 1e-3  # × the tube's length: vertices this close along its axis lie on one ring
LOOP_MIN_VERTICES = 3  # a ring has at least a triangle's worth of vertices
TUBE_ELONGATION = 2.0  # a tube is at least this many times longer than it is thick (a squat block is no tube)


def edge_loops(vertices: np.ndarray, min_gap: float) -> np.ndarray | None:
    """(K, 3) ring centres in order along the principal axis when every vertex of `vertices` (V, 3) lies on one of
    K ≥ 3 flat rings across that axis, at least `min_gap` × the tube's thickness apart (a finely tessellated tube, with
    rings closer than that, is no low-poly tube: it bends anywhere), on a body TUBE_ELONGATION × longer than thick;
    else None.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    _, _, local = principal_frame(vertices)
    length, thickness = float(np.ptp(local[:, 0])), float(np.ptp(local[:, 1:], axis=0).max())
    if length <= 0 or length < TUBE_ELONGATION * thickness:
        return None
    order = np.argsort(local[:, 0], kind="stable")
    t = local[order, 0]
    ring = np.concatenate([[0], np.cumsum(np.diff(t) > LOOP_TOL * length)])
    counts = np.bincount(ring)
    if len(counts) < 3 or counts.min() < LOOP_MIN_VERTICES:
        return None
    starts = np.flatnonzero(np.diff(ring)) + 1
    widths = np.maximum.reduceat(t, np.r_[0, starts]) - np.minimum.reduceat(t, np.r_[0, starts])
    if widths.max() > LOOP_TOL * length:  # vertices chained along the axis: a band, not a ring
        return None
    level = np.bincount(ring, weights=t) / counts
    if np.diff(level).min() < min_gap * thickness:
        return None
    centres = np.stack([np.bincount(ring, weights=vertices[order, k]) / counts for k in range(3)], axis=1)
    return centres
