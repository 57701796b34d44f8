"""Free bones that move as one: neighbouring bones whose transforms carry their vertices alike are merged.

Asked for more bones than a sequence has moving parts (a rigid piece, a still limb), Dem Bones splits a part
among several bones with the same motion; a joint between them is read off no motion at all.
"""

from __future__ import annotations

import numpy as np

from simcore.motion_rig.free_bones import BoneFit


def _touching(faces: np.ndarray, dominant: np.ndarray) -> np.ndarray:
    """(P, 2) int64 bone pairs a < b whose main vertices share a triangle edge."""
    owner = dominant[np.asarray(faces, np.int64)]
    edges = np.concatenate([owner[:, [0, 1]], owner[:, [1, 2]], owner[:, [2, 0]]])
    edges = np.sort(edges[edges[:, 0] != edges[:, 1]], axis=1)
    return np.unique(edges, axis=0) if len(edges) else np.zeros((0, 2), np.int64)


def merge_moving_alike(rest: np.ndarray, faces: np.ndarray, fit: BoneFit, tolerance: float) -> tuple[BoneFit, int]:
    """The fit with each group of touching bones that move alike merged into one, and how many bones went.

    Two bones move alike when the RMS, over frames and over the vertices mainly weighted to either, of the distance
    between each vertex carried by the one transform and by the other is below `tolerance` (metres). A merged bone
    has its members' summed weights and the transform of the heaviest member. rest: (V, 3); faces: (F, 3).
    """
    count = fit.num_bones
    dominant = fit.weights.argmax(axis=1)
    root = list(range(count))

    def find(b: int) -> int:
        while root[b] != b:
            root[b] = root[root[b]]
            b = root[b]
        return b

    for a, b in _touching(faces, dominant).tolist():
        on = np.flatnonzero((dominant == a) | (dominant == b))
        gap = (np.einsum("tij,vj->tvi", fit.transforms[:, a, :3, :3] - fit.transforms[:, b, :3, :3], rest[on])
               + (fit.transforms[:, a, None, :3, 3] - fit.transforms[:, b, None, :3, 3]))
        if np.sqrt(np.square(gap).sum(-1).mean()) < tolerance:
            root[find(a)] = find(b)
    groups = np.array([find(b) for b in range(count)])
    labels, index = np.unique(groups, return_inverse=True)
    if len(labels) == count:
        return fit, 0
    mass = fit.weights.sum(axis=0)
    weights = np.zeros((len(fit.weights), len(labels)))
    keep = np.zeros(len(labels), np.int64)
    for g in range(len(labels)):
        members = np.flatnonzero(index == g)
        weights[:, g] = fit.weights[:, members].sum(axis=1)
        keep[g] = members[np.argmax(mass[members])]
    return BoneFit(weights, fit.transforms[:, keep]), count - len(labels)
