"""Bone segments owned by joints, and point-to-segment distances.

A glTF joint's transform moves the bones to its children rigidly, so joint j owns one segment per child
(j → child). A leaf joint owns a short segment continuing its parent bone (`leaf_extension` × that
bone's length): leaves such as heads, hands and tail tips carry real weight in artist rigs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simcore.geometry.weld import weld_vertices
from simcore.skeleton.types import JointKind, Skeleton

ROWS = 8192  # points per block in closest_on_segments


@dataclass
class JointSegments:
    """heads, tails: (S, 3) float64 segment end points; owner: (S,) int64 joint owning each segment."""

    heads: np.ndarray
    tails: np.ndarray
    owner: np.ndarray


def _repeated(positions: np.ndarray) -> np.ndarray:
    """(J,) bool: joints whose position another joint shares (welded within `weld_vertices`' tolerance)."""
    index = weld_vertices(positions, np.zeros((0, 3), np.int64)).index
    return np.bincount(index, minlength=len(positions))[index] > 1


def joint_segments(skeleton: Skeleton, leaf_extension: float = 0.5) -> JointSegments:
    """Segments of every joint (at least one each; a lone root gets a point) but helper joints
    (JointKind.HELPER), which own none, so nothing is skinned to them; their parents' bones to them remain, but
    for a stale helper: one with only helpers below it whose bind position repeats another joint's (exporters
    write the armature's transform for bones that deform nothing, so a bone to it would cross the body). A joint
    whose children are all stale helpers ends like a leaf."""
    pos = skeleton.positions
    heads, tails, owner = [], [], []
    children = skeleton.children()
    inert = np.array([kind == JointKind.HELPER for kind in skeleton.kinds]) & _repeated(pos)
    for j in range(len(children) - 1, -1, -1):  # children first: a helper is inert when all below it are
        inert[j] &= all(inert[c] for c in children[j])
    for j, kids in enumerate(children):
        if skeleton.kinds[j] == JointKind.HELPER:
            continue
        kids = [c for c in kids if not inert[c]]
        for c in kids:
            heads.append(pos[j])
            tails.append(pos[c])
            owner.append(j)
        if not kids:
            p = skeleton.parents[j]
            heads.append(pos[j])
            tails.append(pos[j] + leaf_extension * (pos[j] - pos[p]) if p >= 0 else pos[j])
            owner.append(j)
    return JointSegments(np.asarray(heads, float), np.asarray(tails, float), np.asarray(owner, np.int64))


def closest_on_segments(points: np.ndarray, heads: np.ndarray, tails: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distances (N, S) float64 from points (N, 3) to segments (S, 3)-(S, 3), and parameters t (N, S) in [0, 1]."""
    p = np.asarray(points, dtype=np.float64)
    d = tails - heads  # (S, 3)
    length2 = np.maximum(np.einsum("sc,sc->s", d, d), 1e-30)
    head_d = np.einsum("sc,sc->s", heads, d)
    head2 = (heads * heads).sum(axis=1)
    dist, t = np.empty((len(p), len(d))), np.empty((len(p), len(d)))
    # A block of rows at a time keeps the temporaries in cache: 247k points × 66 segments in 0.15 s, not 0.8-1.9 s.
    for start in range(0, len(p), ROWS):
        q = p[start:start + ROWS]
        along = q @ d.T - head_d  # (p - h)·d
        t_q = np.clip(along / length2, 0.0, 1.0)
        # |p - h - t d|² expanded so no (N, S, 3) array is built.
        dist2 = (q * q).sum(axis=1)[:, None] - 2.0 * q @ heads.T + head2 - 2.0 * t_q * along + t_q * t_q * length2
        np.sqrt(np.maximum(dist2, 0.0), out=dist[start:start + ROWS])
        t[start:start + ROWS] = t_q
    return dist, t


def joint_distances(points: np.ndarray, segments: JointSegments, num_joints: int) -> np.ndarray:
    """(N, J) float64 Euclidean distance from each point to the nearest segment of each joint."""
    dist, _ = closest_on_segments(points, segments.heads, segments.tails)
    out = np.full((len(points), num_joints), np.inf)
    for s, j in enumerate(segments.owner):
        np.minimum(out[:, j], dist[:, s], out=out[:, j])
    return out
