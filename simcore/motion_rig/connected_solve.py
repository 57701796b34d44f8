"""Bone motion on a joint tree: rigid transforms that keep every child's joint on its parent, fitted to frames.

Block coordinate descent over bones, parents first (the SSDR transform update with the joint fixed): with every
other bone held, bone b's rotation per frame is the weighted Procrustes fit of its share of the residual about
its joint, which its parent carries; the root (and any bone hung from a separate mesh part) also moves its
joint freely.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from simcore.geometry.similarity import rotation_from_covariance

STEP_SHARES = np.array([1.0, 0.5, 0.25, 0.125, 0.0])  # of a joint's step, tried in turn to keep it inside the body


def _procrustes(source: np.ndarray, target: np.ndarray, mass: np.ndarray) -> np.ndarray:
    """(T, 3, 3) rotations R minimising sum_v mass_v |R source_v - target_tv|^2.

    source: (N, 3) centred rest points; target: (N, T, 3) centred targets; mass: (N,) non-negative.
    """
    cov = np.tensordot(source * mass[:, None], target, axes=(0, 0)).transpose(1, 2, 0)  # sum target source^T
    return rotation_from_covariance(cov)


def _turned(rot: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(N, T, 3) points (N, 3) turned by each rotation (T, 3, 3) (vertex-major: one matrix product)."""
    return (points @ rot.reshape(-1, 3).T).reshape(len(points), len(rot), 3)


def _subtrees(parents: np.ndarray) -> list[np.ndarray]:
    """Each bone's descendants and itself (parents first order)."""
    below: list[list[int]] = [[b] for b in range(len(parents))]
    for b in range(len(parents) - 1, -1, -1):
        if parents[b] >= 0:
            below[int(parents[b])].extend(below[b])
    return [np.asarray(sorted(s), np.int64) for s in below]


def connected_transforms(rest: np.ndarray, frames: np.ndarray, weights: np.ndarray, parents: np.ndarray,
                         joints: np.ndarray, floating: np.ndarray, start: np.ndarray, *, sweeps: int,
                         joint_regularisation: float, min_gain: float = 0.0,
                         anchors: np.ndarray | None = None,
                         inside: Callable[[np.ndarray], np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """(T, B, 4, 4) rigid transforms with each bone's joint carried by its parent in every frame, the re-fitted
    (B, 3) rest joints (the sweep, or the start, of least squared error over every frame and vertex), and the
    number of sweeps run.

    rest: (V, 3) bind pose; frames: (T, V, 3); weights: (V, B) rows summing to 1; parents: (B,) parents first,
    root -1; joints: (B, 3) rest joints; floating: (B,) bool bones whose joint moves freely (the root's);
    start: (T, B, 4, 4) transforms whose rotations (and floating bones' translations) seed the fit;
    joint_regularisation: per-frame pull of a joint towards its anchor (`anchors` (B, 3), default the given
    joints), which decides the directions the motion leaves open (along a hinge's axis) so joints do not drift.
    sweeps: at most this many; they stop after one that cuts the squared error by less than `min_gain` (a share).
    inside: (N, 3) points → (N,) bool, the body's solid: a joint inside it takes at most the share of its step
    (1, ½, ¼, ⅛ or none) that keeps it inside, so the fit cannot carry joints out of the body along the directions
    the motion leaves loose; None lets joints go anywhere.
    """
    count, steps = weights.shape[1], frames.shape[0]
    joints = joints.copy()
    anchors = joints.copy() if anchors is None else anchors
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

    def contribution(b: int) -> np.ndarray:  # (n_b, T, 3) bone b's weighted share of its vertices
        on = support[b]
        return weights[on, b, None, None] * (_turned(rot[:, b], rest[on]) + trans[None, :, b])

    shares = [contribution(b) for b in range(count)]
    resid = frames.transpose(1, 0, 2).copy()  # (V, T, 3) frames minus the present fit, vertex-major
    for b in range(count):
        resid[support[b]] -= shares[b]
    subtrees = _subtrees(parents)
    below = np.zeros((count, count))
    for b, sub in enumerate(subtrees):
        below[sub, b] = 1.0
    subtree_share = weights @ below  # (V, B) weight each vertex gives to bone b's subtree
    share_gram = subtree_share.T @ subtree_share  # (B, B) overlap of two subtrees' shares

    def _move_joints() -> None:
        """Exact least-squares step of each joint b in turn: it shifts every translation of b's subtree by
        (R_p - R_b) dp. The share-weighted residuals `pull` follow each step through `share_gram`, and the
        residual and shares take the summed shifts once at the end (the same steps, without a pass over the
        vertices per joint)."""
        pull = (subtree_share.T @ resid.reshape(len(resid), -1)).reshape(count, steps, 3)  # share-weighted residual
        shifts = np.zeros((count, steps, 3))
        for b in range(count):
            if floating[b]:
                continue
            lever = rot[:, parents[b]] - rot[:, b]  # (T, 3, 3)
            lhs = (np.einsum("tki,tkj->ij", lever, lever) * share_gram[b, b]
                   + joint_regularisation * steps * np.eye(3))
            rhs = np.einsum("tki,tk->i", lever, pull[b]) + joint_regularisation * steps * (anchors[b] - joints[b])
            step = np.linalg.solve(lhs, rhs)
            if inside is not None and inside(joints[b][None])[0]:
                fits = np.append(inside(joints[b] + STEP_SHARES[:-1, None] * step), True)  # the last share is 0
                step = STEP_SHARES[int(np.argmax(fits))] * step
            shift = lever @ step  # (T, 3)
            joints[b] += step
            shifts[b] = shift
            pull -= share_gram[:, b, None, None] * shift[None]
        moved = below @ shifts.reshape(count, -1)  # (B, T*3) summed shift of each bone's translation
        trans[:] += moved.reshape(count, steps, 3).transpose(1, 0, 2)
        resid[:] -= (subtree_share @ shifts.reshape(count, -1)).reshape(-1, steps, 3)
        for c in range(count):
            if np.any(moved[c]):
                shares[c] += weights[support[c], c, None, None] * moved[c].reshape(steps, 3)[None]

    kids = [[c for c in range(count) if parents[c] == b and not floating[c] and len(support[c])] for b in range(count)]

    sub_on = [np.flatnonzero(subtree_share[:, c] > 0) for c in range(count)]

    def wanted_head(c: int) -> tuple[np.ndarray, float]:
        """(T, 3) the joint of bone c that best fits the residual when c's whole subtree moves with it (each vertex
        by its subtree share), and that fit's mass."""
        on = sub_on[c]
        share = subtree_share[on, c]
        mass = float(share @ share)
        head = np.einsum("tij,j->ti", rot[:, c], joints[c]) + trans[:, c]
        return head + np.tensordot(share, resid[on], axes=(0, 0)) / mass, mass

    best = (float(np.square(resid).sum()), rot.copy(), trans.copy(), joints.copy())
    done = 0
    for _ in range(sweeps):
        done += 1
        for b in range(count):
            carry(b)  # the parent moved since this bone's last update
            on, w = support[b], weights[support[b], b]
            own = contribution(b)
            resid[on] -= own - shares[b]
            heads = [wanted_head(c) for c in kids[b]]  # children's joints ride on this bone: fit them too
            source = np.concatenate([rest[on], joints[kids[b]]])
            target = np.concatenate([(resid[on] + own) / w[:, None, None],
                                     np.reshape([h for h, _ in heads], (len(heads), steps, 3))])
            mass = np.concatenate([w * w, [m for _, m in heads]])
            if len(mass) == 0:
                continue
            if floating[b]:
                pivot = (mass @ source) / mass.sum()
                goal = np.tensordot(mass, target, axes=(0, 0)) / mass.sum()
            else:
                pivot = joints[b]
                goal = np.einsum("tij,j->ti", rot[:, b], joints[b]) + trans[:, b]
            rot[:, b] = _procrustes(source - pivot, target - goal[None], mass)
            trans[:, b] = goal - np.einsum("tij,j->ti", rot[:, b], pivot)
            shares[b] = contribution(b)
            resid[on] -= shares[b] - own
        _move_joints()
        error = float(np.square(resid).sum())
        if error >= (1.0 - min_gain) * best[0]:  # this sweep gained too little to go on
            if error < best[0]:
                best = (error, rot.copy(), trans.copy(), joints.copy())
            break
        best = (error, rot.copy(), trans.copy(), joints.copy())
    _, rot, trans, joints = best  # a bone's step fits its own share and its children's joints, not the whole
    # error, so a sweep can lose ground: the best state (the start included) is kept
    out = np.tile(np.eye(4), (steps, count, 1, 1))
    out[:, :, :3, :3] = rot
    out[:, :, :3, 3] = trans
    return out, joints, done
