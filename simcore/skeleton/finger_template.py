"""Finger joints from the Mixamo hand template when the fingers exist but touch (no medial branch per finger).

Evidence that a hand has fingers: planes across the hand's finger region cut the mesh into several closed
loops (one per finger shell), while a mitten cuts into one. When the median loop count over those planes is
at least MIN_LOOPS, the 15 joints of a hand are laid out in the hand's own frame: along = wrist → fingertip
direction, in units of the hand length; across = the palm's widest direction, towards the index (the front
finger: palms down or in, see `hands`); normal = along × across, mirrored for the right hand. The template
offsets are the mean of reference Mixamo hands (both sides) read in that frame.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from simcore.skeleton.mixamo import FINGERS

# (along, across, normal) per phalanx, × hand length, from the wrist (the Hand joint).
TEMPLATE: dict[str, tuple[tuple[float, float, float], ...]] = {
    "Thumb": ((0.15, 0.13, 0.03), (0.31, 0.24, 0.08), (0.45, 0.35, 0.13)),
    "Index": ((0.55, 0.12, -0.03), (0.71, 0.12, -0.03), (0.85, 0.12, -0.03)),
    "Middle": ((0.55, 0.0, 0.0), (0.72, 0.0, 0.0), (0.85, 0.0, 0.0)),
    "Ring": ((0.52, -0.11, 0.04), (0.66, -0.11, 0.04), (0.78, -0.11, 0.04)),
    "Pinky": ((0.46, -0.19, 0.1), (0.6, -0.19, 0.1), (0.72, -0.19, 0.1)),
}
SLICES = (0.6, 0.65, 0.7, 0.75, 0.8)  # × hand length: planes through the fingers, past the knuckles
MIN_LOOPS = 4  # closed section loops needed to believe in fingers (a mitten gives 1)


def section_loops(vertices: np.ndarray, faces: np.ndarray, origin: np.ndarray, normal: np.ndarray) -> int:
    """Number of connected section curves where the plane (origin (3,), unit normal (3,)) cuts the mesh.

    vertices: (V, 3) float64, faces: (F, 3) int64. Segment ends are welded on a grid 1e-6 × the mesh size.
    """
    import trimesh

    mesh = trimesh.Trimesh(vertices, faces, process=False)
    segments = trimesh.intersections.mesh_plane(mesh, normal, origin)
    if len(segments) == 0:
        return 0
    weld = 1e-6 * float(np.ptp(vertices, axis=0).max()) or 1e-12
    _, ends = np.unique(np.round(segments.reshape(-1, 3) / weld).astype(np.int64), axis=0, return_inverse=True)
    ends = ends.ravel()
    n = int(ends.max()) + 1
    graph = sp.coo_matrix((np.ones(len(ends) // 2), (ends[0::2], ends[1::2])), shape=(n, n))
    return int(connected_components(graph, directed=False)[0])


def template_fingers(vertices: np.ndarray, faces: np.ndarray, wrist: np.ndarray, elbow: np.ndarray,
                     forward: np.ndarray, side: str) -> tuple[dict[str, np.ndarray] | None, dict[str, Any]]:
    """The 15 finger joints of one hand ("Thumb1" … "Pinky3" → (3,)) from the template, or None with a reason.

    vertices/faces: the hand crop (V, 3) float64 / (F, 3) int64; wrist, elbow: (3,) fitted Hand and ForeArm
    joints; forward: (3,) unit facing; side: "Left" or "Right".
    """
    forearm = float(np.linalg.norm(wrist - elbow))
    along_dir = (wrist - elbow) / max(forearm, 1e-12)
    rel = vertices - wrist
    along = rel @ along_dir
    perp = rel - along[:, None] * along_dir
    hand = (along > 0) & (np.linalg.norm(perp, axis=1) < 0.5 * forearm)
    if hand.sum() < 20:
        return None, {"reason": "too few hand vertices past the wrist"}
    length = float(np.percentile(along[hand], 99.5))
    if length < 0.2 * forearm:
        return None, {"reason": "the hand is too short for fingers"}
    loops = [section_loops(vertices, faces, wrist + s * length * along_dir, along_dir) for s in SLICES]
    if float(np.median(loops)) < MIN_LOOPS:
        return None, {"reason": f"finger sections show {int(np.median(loops))} loops (mitten)", "loops": loops}
    spread = perp[hand & (along > 0.3 * length)]
    _, _, axes = np.linalg.svd(spread - spread.mean(axis=0), full_matrices=False)
    across = axes[0] - (axes[0] @ along_dir) * along_dir
    across /= max(float(np.linalg.norm(across)), 1e-12)
    if across @ forward < 0:  # the index is the front finger
        across = -across
    normal = np.cross(along_dir, across) * (1.0 if side == "Left" else -1.0)
    out = {f"{finger}{k}": wrist + length * (a * along_dir + c * across + n * normal)
           for finger in FINGERS for k, (a, c, n) in enumerate(TEMPLATE[finger], start=1)}
    return out, {"template": True, "loops": loops}
