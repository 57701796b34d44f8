"""Bone segments owned by joints, and point-to-segment distances.

A glTF joint's transform moves the bones to its children rigidly, so joint j owns one segment per child
(j → child). A leaf joint owns a segment too: leaves such as heads, hands and tail tips carry real weight in artist
rigs. Given the mesh, a leaf's segment points into the part of the mesh nearest to it (`leaf_tails`); without it, it
continues the parent bone (`leaf_extension` × that bone's length), which misleads wherever the parent is not in line
with the leaf: a leg hung from a root at the origin would point up into the arms.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simcore.geometry.weld import weld_vertices
from simcore.skeleton.types import JointKind, Skeleton

ROWS = 8192  # points per block in closest_on_segments
LEAF_QUANTILE = 0.9  # how far along its direction a leaf's part reaches: this quantile of its points' offsets
LEAF_MIN_POINTS = 3  # fewer points nearest to a leaf say nothing of its direction
LEAF_COHERENCE = 0.25  # a part around the leaf (a tube's end cap) leans no way: its mean offset is short
TIE = 1e-9  # relative distance within which a point is as near to two segments


@dataclass
class JointSegments:
    """heads, tails: (S, 3) float64 segment end points; owner: (S,) int64 joint owning each segment; leaf: (S,)
    bool, the segment of a joint with no bone to a child."""

    heads: np.ndarray
    tails: np.ndarray
    owner: np.ndarray
    leaf: np.ndarray


def _repeated(positions: np.ndarray) -> np.ndarray:
    """(J,) bool: joints whose position another joint shares (welded within `weld_vertices`' tolerance)."""
    index = weld_vertices(positions, np.zeros((0, 3), np.int64)).index
    return np.bincount(index, minlength=len(positions))[index] > 1


def joint_segments(skeleton: Skeleton, leaf_extension: float = 0.5, points: np.ndarray | None = None) -> JointSegments:
    """Segments of every joint (at least one each; a lone root gets a point) but helper joints
    (JointKind.HELPER), which own none, so nothing is skinned to them; their parents' bones to them remain, but
    for a stale helper: one with only helpers below it whose bind position repeats another joint's (exporters
    write the armature's transform for bones that deform nothing, so a bone to it would cross the body). A joint
    whose children are all stale helpers ends like a leaf. A leaf's segment: `leaf_tails` with the mesh's
    `points` (V, 3) when given, else the parent bone continued by `leaf_extension` × its length."""
    pos = skeleton.positions
    heads, tails, owner, leaf = [], [], [], []
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
            leaf.append(False)
        if not kids:
            p = skeleton.parents[j]
            heads.append(pos[j])
            tails.append(pos[j] + leaf_extension * (pos[j] - pos[p]) if p >= 0 else pos[j])
            owner.append(j)
            leaf.append(True)
    segments = JointSegments(np.asarray(heads, float), np.asarray(tails, float), np.asarray(owner, np.int64),
                             np.asarray(leaf, bool))
    return segments if points is None else leaf_tails(segments, points, leaf_extension)


def leaf_tails(segments: JointSegments, points: np.ndarray, extension: float) -> JointSegments:
    """`segments` with each leaf's segment pointing into the mesh part nearest to it: the points (V, 3) whose
    nearest segment is the leaf (its own a point at its head), their mean offset from the head giving the
    direction and the LEAF_QUANTILE of their offsets along it the reach; the tail lies `extension` × the reach
    out. A leaf no point lies nearest to, or whose part lies all around it rather than to one side (the mean offset
    under LEAF_COHERENCE × the mean distance), keeps its segment."""
    leaf = segments.leaf
    if not leaf.any() or len(points) == 0:
        return segments
    tails = segments.tails.copy()
    tails[leaf] = segments.heads[leaf]
    dist, _ = closest_on_segments(points, segments.heads, tails)
    # The parent's bone ends where the leaf starts: what lies beyond its end is as near to both, and is the leaf's.
    nearest = dist <= dist.min(axis=1, keepdims=True) * (1.0 + TIE) + TIE * float(np.ptp(points, axis=0).max())
    for s in np.flatnonzero(leaf):
        offsets = points[nearest[:, s]] - segments.heads[s]
        mean = offsets.mean(axis=0) if len(offsets) else np.zeros(3)
        norm = float(np.linalg.norm(mean))
        if len(offsets) < LEAF_MIN_POINTS or norm <= LEAF_COHERENCE * float(np.linalg.norm(offsets, axis=1).mean()):
            tails[s] = segments.tails[s]
            continue
        along = float(np.quantile(offsets @ (mean / norm), LEAF_QUANTILE))
        tails[s] = segments.heads[s] + extension * along * mean / norm
    return JointSegments(segments.heads, tails, segments.owner, leaf)


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
