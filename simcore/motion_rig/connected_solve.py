"""Bone motion on a joint tree: rigid transforms that keep every child's joint on its parent, fitted to frames.

Block coordinate descent over bones, parents first (the SSDR transform update with the joint fixed): with every
other bone held, bone b's rotation per frame is the weighted Procrustes fit of its share of the residual about
its joint, which its parent carries; the root (and any bone hung from a separate mesh part) also moves its
joint freely.
"""

from __future__ import annotations

import numpy as np


def _procrustes(source: np.ndarray, target: np.ndarray, mass: np.ndarray) -> np.ndarray:
    """(T, 3, 3) rotations R minimising sum_v mass_v |R source_v - target_tv|^2.

    source: (N, 3) centred rest points; target: (T, N, 3) centred targets; mass: (N,) non-negative.
    """
    cov = np.swapaxes((source * mass[:, None]).T @ target, 1, 2)  # sum target source^T, (T, 3, 3)
    u, _, vt = np.linalg.svd(cov)
    flip = np.sign(np.linalg.det(u @ vt))
    u[:, :, 2] *= flip[:, None]
    return u @ vt


def _turned(rot: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(T, N, 3) points (N, 3) turned by each rotation (T, 3, 3)."""
    return np.matmul(points[None], np.swapaxes(rot, 1, 2))


def _subtrees(parents: np.ndarray) -> list[np.ndarray]:
    """Each bone's descendants and itself (parents first order)."""
    below: list[list[int]] = [[b] for b in range(len(parents))]
    for b in range(len(parents) - 1, -1, -1):
        if parents[b] >= 0:
            below[int(parents[b])].extend(below[b])
    return [np.asarray(sorted(s), np.int64) for s in below]


def connected_transforms(rest: np.ndarray, frames: np.ndarray, weights: np.ndarray, parents: np.ndarray,
                         joints: np.ndarray, floating: np.ndarray, start: np.ndarray, *, sweeps: int,
                         joint_regularisation: float) -> tuple[np.ndarray, np.ndarray]:
    """(T, B, 4, 4) rigid transforms with each bone's joint carried by its parent in every frame, and the
    re-fitted (B, 3) rest joints.

    rest: (V, 3) bind pose; frames: (T, V, 3); weights: (V, B) rows summing to 1; parents: (B,) parents first,
    root -1; joints: (B, 3) rest joints; floating: (B,) bool bones whose joint moves freely (the root's);
    start: (T, B, 4, 4) transforms whose rotations (and floating bones' translations) seed the fit;
    joint_regularisation: per-frame pull of a joint towards where it is, for directions the motion leaves open.
    """
    count, steps = weights.shape[1], frames.shape[0]
    joints = joints.copy()
    rot = start[:, :, :3, :3].copy()
    trans = start[:, :, :3, 3].copy()

    def carry(b: int) -> None:  # child joint = where the parent takes it
        p = parents[b]
        if p >= 0 and not floating[b]:
            head = np.einsum("tij,j->ti", rot[:, p], joints[b]) + trans[:, p]
            trans[:, b] = head - np.einsum("tij,j->ti", rot[:, b], joints[b])

    for b in range(count):
        carry(b)
    support = [np.flatnonzero(weights[:, b] > 0) for b in range(count)]

    def contribution(b: int) -> np.ndarray:  # (T, n_b, 3) bone b's weighted share of its vertices
        on = support[b]
        return weights[on, b, None] * (_turned(rot[:, b], rest[on]) + trans[:, b, None])

    shares = [contribution(b) for b in range(count)]
    resid = frames.copy()  # frames minus the present fit
    for b in range(count):
        resid[:, support[b]] -= shares[b]
    subtrees = _subtrees(parents)
    below = np.zeros((count, count))
    for b, sub in enumerate(subtrees):
        below[sub, b] = 1.0
    subtree_share = weights @ below  # (V, B) weight each vertex gives to bone b's subtree

    def _move_joint(b: int) -> None:
        """Exact least-squares step of joint b: it shifts every translation of b's subtree by (R_p - R_b) dp."""
        share = subtree_share[:, b]
        on = np.flatnonzero(share > 0)
        s_on = share[on]
        lever = rot[:, parents[b]] - rot[:, b]  # (T, 3, 3)
        pull = np.tensordot(s_on, resid[:, on], axes=(0, 1))  # (T, 3) share-weighted residual
        lhs = np.einsum("tki,tkj->ij", lever, lever) * float(s_on @ s_on) + joint_regularisation * steps * np.eye(3)
        rhs = np.einsum("tki,tk->i", lever, pull)
        step = np.linalg.solve(lhs, rhs)
        shift = lever @ step  # (T, 3)
        joints[b] += step
        trans[:, subtrees[b]] += shift[:, None]
        resid[:, on] -= s_on[None, :, None] * shift[:, None]
        for c in subtrees[b].tolist():
            shares[c] += weights[support[c], c, None] * shift[:, None]

    kids = [[c for c in range(count) if parents[c] == b and not floating[c] and len(support[c])] for b in range(count)]

    def wanted_head(c: int) -> tuple[np.ndarray, float]:
        """(T, 3) where bone c's own vertices would put its joint under its present rotation, and their mass."""
        on, w = support[c], weights[support[c], c]
        target = (resid[:, on] + shares[c]) / w[:, None]
        mass = w * w
        heads = target - _turned(rot[:, c], rest[on] - joints[c])
        return np.tensordot(mass, heads, axes=(0, 1)) / mass.sum(), float(mass.sum())

    for _ in range(sweeps):
        for b in range(count):
            carry(b)  # the parent moved since this bone's last update
            on, w = support[b], weights[support[b], b]
            own = contribution(b)
            resid[:, on] -= own - shares[b]
            heads = [wanted_head(c) for c in kids[b]]  # children's joints ride on this bone: fit them too
            source = np.concatenate([rest[on], joints[kids[b]]])
            target = np.concatenate([(resid[:, on] + own) / w[:, None],
                                     np.reshape([h for h, _ in heads], (len(heads), steps, 3)).swapaxes(0, 1)], axis=1)
            mass = np.concatenate([w * w, [m for _, m in heads]])
            if len(mass) == 0:
                continue
            if floating[b]:
                pivot = (mass @ source) / mass.sum()
                goal = np.tensordot(mass, target, axes=(0, 1)) / mass.sum()
            else:
                pivot = joints[b]
                goal = np.einsum("tij,j->ti", rot[:, b], joints[b]) + trans[:, b]
            rot[:, b] = _procrustes(source - pivot, target - goal[:, None], mass)
            trans[:, b] = goal - np.einsum("tij,j->ti", rot[:, b], pivot)
            shares[b] = contribution(b)
            resid[:, on] -= shares[b] - own
        for b in range(count):
            if not floating[b]:
                _move_joint(b)
    for b in range(count):  # children follow their parents' last update
        carry(b)
    out = np.tile(np.eye(4), (steps, count, 1, 1))
    out[:, :, :3, :3] = rot
    out[:, :, :3, 3] = trans
    return out, joints
