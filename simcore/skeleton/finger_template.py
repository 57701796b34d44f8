"""Finger joints from the Mixamo hand template when the fingers exist but touch (no medial branch per finger).

Evidence that a hand has fingers: planes across the hand's finger region cut the mesh into several closed
loops (one per finger shell; the thumb ends before them), while a mitten cuts into one. The count read is the
one that at least two planes reach (fingers of unequal length leave the farther planes first): four or more
loops make a five-fingered hand, three a four-fingered one (a thumb and three fingers, `mixamo.FOUR_FINGERS`).
The joints of a hand are laid out in the hand's own frame: along = wrist → fingertip direction, in units of the
hand length; across = the palm's widest direction, towards the index (the front finger: palms down or in, see
`hands`); normal = along × across, mirrored for the right hand. The template offsets are the mean of reference
Mixamo hands (both sides) read in that frame. A four-fingered hand keeps the thumb's offsets and the first three
fingers' offsets along the hand; each finger's place across the palm and off its plane is read from the section
loops themselves (their centres on the planes that cut exactly three, front to back), as no reference hand has
that layout.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from simcore.skeleton.mixamo import FINGERS, FOUR_FINGERS

# (along, across, normal) per phalanx, × hand length, from the wrist (the Hand joint).
TEMPLATE: dict[str, tuple[tuple[float, float, float], ...]] = {
    "Thumb": ((0.15, 0.13, 0.03), (0.31, 0.24, 0.08), (0.45, 0.35, 0.13)),
    "Index": ((0.55, 0.12, -0.03), (0.71, 0.12, -0.03), (0.85, 0.12, -0.03)),
    "Middle": ((0.55, 0.0, 0.0), (0.72, 0.0, 0.0), (0.85, 0.0, 0.0)),
    "Ring": ((0.52, -0.11, 0.04), (0.66, -0.11, 0.04), (0.78, -0.11, 0.04)),
    "Pinky": ((0.46, -0.19, 0.1), (0.6, -0.19, 0.1), (0.72, -0.19, 0.1)),
}
SLICES = (0.6, 0.65, 0.7, 0.75, 0.8)  # × hand length: planes through the fingers, past the knuckles
# The finger sets a hand may have, tried in this order, with the section loops (fingers past the thumb) each shows.
FINGER_LOOPS: dict[tuple[str, ...], int] = {FINGERS: 4, FOUR_FINGERS: 3}
HAND_KINDS = tuple(FINGER_LOOPS)
AGREEING_PLANES = 2  # planes that must reach a loop count for it to count


def section_loops(vertices: np.ndarray, faces: np.ndarray, origin: np.ndarray, normal: np.ndarray) -> list[np.ndarray]:
    """The centres (3,) of the connected section curves where the plane (origin (3,), unit normal (3,)) cuts the
    mesh (the mean of each curve's segment ends), one per curve; [] when the plane misses it.

    vertices: (V, 3) float64, faces: (F, 3) int64. Segment ends are welded on a grid 1e-6 × the mesh size.
    """
    import trimesh

    mesh = trimesh.Trimesh(vertices, faces, process=False)
    segments = trimesh.intersections.mesh_plane(mesh, normal, origin)
    if len(segments) == 0:
        return []
    points = segments.reshape(-1, 3)
    weld = 1e-6 * float(np.ptp(vertices, axis=0).max()) or 1e-12
    _, ends = np.unique(np.round(points / weld).astype(np.int64), axis=0, return_inverse=True)
    ends = ends.ravel()
    n = int(ends.max()) + 1
    graph = sp.coo_matrix((np.ones(len(ends) // 2), (ends[0::2], ends[1::2])), shape=(n, n))
    count, label = connected_components(graph, directed=False)
    curve = label[ends]
    return [points[curve == k].mean(axis=0) for k in range(count)]


def finger_names(loop_counts: list[int], kinds: tuple[tuple[str, ...], ...] = HAND_KINDS) -> tuple[str, ...] | None:
    """The fingers a hand shows from its planes' loop counts: the first of `kinds` whose FINGER_LOOPS at least
    AGREEING_PLANES planes reach; None for a mitten."""
    reached = sorted(loop_counts, reverse=True)[AGREEING_PLANES - 1] if len(loop_counts) >= AGREEING_PLANES else 0
    return next((f for f in kinds if reached >= FINGER_LOOPS[f]), None)


def template_fingers(vertices: np.ndarray, faces: np.ndarray, wrist: np.ndarray, elbow: np.ndarray,
                     forward: np.ndarray, side: str, kinds: tuple[tuple[str, ...], ...] = HAND_KINDS,
                     ) -> tuple[dict[str, np.ndarray] | None, dict[str, Any]]:
    """The 15 (or 12) finger joints of one hand ("Thumb1" … "Pinky3" → (3,)) from the template, or None with a
    reason.

    vertices/faces: the hand crop (V, 3) float64 / (F, 3) int64; wrist, elbow: (3,) fitted Hand and ForeArm
    joints; forward: (3,) unit facing; side: "Left" or "Right"; kinds: the finger sets allowed (HAND_KINDS).
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
    sections = [section_loops(vertices, faces, wrist + s * length * along_dir, along_dir) for s in SLICES]
    loops = [len(c) for c in sections]
    names = finger_names(loops, kinds)
    three = [np.array(c) - wrist for c in sections if len(c) == FINGER_LOOPS[FOUR_FINGERS]]
    if names == FOUR_FINGERS and not three:
        return None, {"reason": "no finger section shows three fingers", "loops": loops}
    if names is None:
        return None, {"reason": f"finger sections show {max(loops)} loops on fewer than {AGREEING_PLANES} planes "
                                "(mitten)", "loops": loops}
    spread = perp[hand & (along > 0.3 * length)]
    _, _, axes = np.linalg.svd(spread - spread.mean(axis=0), full_matrices=False)
    across = axes[0] - (axes[0] @ along_dir) * along_dir
    across /= max(float(np.linalg.norm(across)), 1e-12)
    if across @ forward < 0:  # the index is the front finger
        across = -across
    normal = np.cross(along_dir, across) * (1.0 if side == "Left" else -1.0)
    offsets = {f: TEMPLATE[f] for f in names}
    if names == FOUR_FINGERS:
        placed = np.mean([sorted(((p @ across, p @ normal) for p in c), reverse=True) for c in three], axis=0) / length
        offsets.update({f: tuple((a, float(placed[i][0]), float(placed[i][1])) for a, _, _ in TEMPLATE[row])
                        for i, (f, row) in enumerate(zip(FOUR_FINGERS[1:], FINGERS[1:]))})
    out = {f"{finger}{k}": wrist + length * (a * along_dir + c * across + n * normal)
           for finger in names for k, (a, c, n) in enumerate(offsets[finger], start=1)}
    return out, {"template": True, "loops": loops, "fingers": len(names)}
