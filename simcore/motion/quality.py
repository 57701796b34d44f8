"""Quality scores of an animated, skinned character: foot sliding and self-penetration (LBS result)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from simcore.motion.types import JointAnimation
from simcore.skeleton import kinematics
from simcore.skeleton.types import Skeleton
from simcore.skinning.lbs import linear_blend

SOLE_BAND = 0.02  # vertices this fraction of the height above the lowest one form the soles
CONTACT_BAND = 0.02  # a sole vertex this close to the ground is in contact
MAX_PENETRATION_FRAMES = 24
MAX_PENETRATION_VERTICES = 4000


def skin_matrices(skeleton: Skeleton, anim: JointAnimation) -> np.ndarray:
    """(T, J, 4, 4) LBS matrices of every frame of `anim` (target joint order)."""
    world = kinematics.global_transforms(skeleton, kinematics.compose(anim.rotations, anim.translations))
    return kinematics.skinning_matrices(skeleton, world)


def foot_sliding(vertices: np.ndarray, weights: sp.csr_matrix, mats: np.ndarray, fps: float) -> dict[str, float]:
    """Horizontal speed of sole vertices while they touch the ground.

    vertices: (V, 3) bind pose; weights (V, J); mats (T, J, 4, 4). The ground is the rest pose's lowest
    point. Returns mean sliding speed in m/s and in heights/s, and the fraction of contact samples.
    """
    height = float(np.ptp(vertices[:, 1])) or 1.0
    ground = float(vertices[:, 1].min())
    soles = np.flatnonzero(vertices[:, 1] <= ground + SOLE_BAND * height)
    if len(mats) < 2 or not len(soles):
        return {"sliding_m_per_s": 0.0, "sliding_heights_per_s": 0.0, "contact_fraction": 0.0}
    posed = linear_blend(vertices[soles], weights[soles], mats)  # (T, S, 3)
    touch = posed[..., 1] <= ground + CONTACT_BAND * height
    both = touch[1:] & touch[:-1]
    step = np.linalg.norm(np.diff(posed[..., [0, 2]], axis=0), axis=2) * fps
    speed = float(step[both].mean()) if both.any() else 0.0
    return {
        "sliding_m_per_s": round(speed, 5),
        "sliding_heights_per_s": round(speed / height, 5),
        "contact_fraction": round(float(touch.mean()), 4),
    }


def _segment_distance(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N, B) distance of points (N, 3) to segments a→b (B, 3)."""
    ab = b - a
    ap = points[:, None, :] - a[None]
    u = np.clip(np.einsum("nbk,bk->nb", ap, ab) / np.maximum((ab ** 2).sum(1), 1e-12), 0.0, 1.0)
    return np.linalg.norm(ap - u[..., None] * ab[None], axis=2)


def _tree_distance(parents: np.ndarray, limit: int) -> np.ndarray:
    """(J, J) bool: joints within `limit` edges of each other in the skeleton tree."""
    j = len(parents)
    adj = np.eye(j, dtype=bool)
    for c, p in enumerate(parents):
        if p >= 0:
            adj[c, p] = adj[p, c] = True
    near = adj.copy()
    for _ in range(limit - 1):
        near = (near.astype(np.int64) @ adj.astype(np.int64)) > 0
    return near


def self_penetration(skeleton: Skeleton, vertices: np.ndarray, weights: sp.csr_matrix, mats: np.ndarray) -> dict[str, float]:
    """Capsule proxy for self-intersection: the share of (vertex, frame) samples that sink deeper than half
    a capsule radius into the capsule of a bone at least 3 tree edges away from the vertex's own bone,
    minus the share at rest (so a pose that merely keeps the rest contacts scores 0).

    Each bone is the segment from a joint to the mean of its children, its radius the median distance of
    the vertices that joint dominates. mats: (T, J, 4, 4); up to 24 frames and 4,000 vertices are used.
    """
    children = skeleton.children()
    bones = [j for j in range(skeleton.num_joints) if children[j]]
    w = sp.csr_matrix(weights)
    rng = np.random.default_rng(0)
    keep = np.sort(rng.choice(len(vertices), min(len(vertices), MAX_PENETRATION_VERTICES), replace=False))
    verts, wk = vertices[keep], w[keep]
    owner = np.asarray(wk.argmax(axis=1)).ravel()
    ends = np.array([skeleton.positions[children[j]].mean(0) for j in bones]).reshape(-1, 3)
    starts = skeleton.positions[bones]
    rest_d = _segment_distance(verts, starts, ends)
    radius = np.array([np.median(rest_d[owner == j, k]) if np.any(owner == j) else 0.0 for k, j in enumerate(bones)])
    valid = radius > 0
    related = _tree_distance(skeleton.parents, 2)[owner][:, bones]  # (N, B)

    def share(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
        d = _segment_distance(points, a, b)
        inside = (d < 0.5 * radius[None]) & valid[None] & ~related
        return float(inside.any(axis=1).mean())

    base = share(verts, starts, ends)
    frames = np.unique(np.linspace(0, len(mats) - 1, min(len(mats), MAX_PENETRATION_FRAMES)).astype(np.int64))
    posed = linear_blend(verts, wk, mats[frames])
    joint_pos = np.einsum("tjab,jb->tja", mats[frames][..., :3, :3], skeleton.positions) + mats[frames][..., :3, 3]
    scores = []
    for k in range(len(frames)):
        p = joint_pos[k]
        ends_k = np.array([p[children[j]].mean(0) for j in bones]).reshape(-1, 3)
        scores.append(share(posed[k], p[bones], ends_k))
    return {"penetration_fraction": round(max(float(np.mean(scores)) - base, 0.0), 5), "rest_fraction": round(base, 5)}
