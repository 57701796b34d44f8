"""Joints between free bones: which bones touch, and the point about which each touching pair rotates."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp


@dataclass
class BonePairs:
    """Touching bone pairs and the joint each pair would have.

    pairs:    (P, 2) int64 bone indices a < b.
    pivots:   (P, 3) float64 rest-pose point that both bones of a pair move most alike (the joint).
    mismatch: (P,) float64 RMS over frames of the distance between that point carried by either bone (metres):
              near zero for a true joint, large for bones that only touch.
    overlap:  (P,) float64 how much skinning the two bones share around their border (vertex-weight products).
    borders:  (P, 3) float64 centre of the pair's border (the overlap-weighted mean of the vertices there).
    stiffness: (P, 3, 3) float64 how firmly the relative motion pins the pivot, per direction (the per-frame
              normal matrix of the pivot fit: near zero along a hinge's axis, zero for bones that never bend).
    """

    pairs: np.ndarray
    pivots: np.ndarray
    mismatch: np.ndarray
    overlap: np.ndarray
    borders: np.ndarray
    stiffness: np.ndarray


def _vertex_adjacency(faces: np.ndarray, count: int) -> sp.csr_matrix:
    """(V, V) row-normalised 1-ring averaging operator, each vertex included."""
    f = np.asarray(faces, dtype=np.int64)
    rows = np.concatenate([f[:, 0], f[:, 1], f[:, 2], f[:, 1], f[:, 2], f[:, 0], np.arange(count)])
    cols = np.concatenate([f[:, 1], f[:, 2], f[:, 0], f[:, 0], f[:, 1], f[:, 2], np.arange(count)])
    a = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(count, count))
    a.data[:] = 1.0
    return sp.diags(1.0 / np.asarray(a.sum(axis=1)).ravel()) @ a


def bone_pairs(rest: np.ndarray, faces: np.ndarray, weights: np.ndarray, transforms: np.ndarray, *,
               spread: int, pivot_regularisation: float) -> BonePairs:
    """Bones whose skinning regions meet on the surface, with each pair's joint.

    rest: (V, 3); faces: (F, 3); weights: (V, B); transforms: (T, B, 4, 4) rest → frame t.
    spread: 1-ring smoothing steps that make neighbouring regions overlap before pairs are read off.
    pivot_regularisation: pull (per frame) of the joint towards the centre of the pair's border; it only
    decides the directions that the relative motion leaves open (a hinge axis, bones that never bend).
    """
    smooth = np.asarray(weights, dtype=np.float64)
    step = _vertex_adjacency(faces, len(rest))
    for _ in range(spread):
        smooth = step @ smooth
    share = smooth.T @ smooth  # (B, B) border strength
    a_idx, b_idx = np.nonzero(np.triu(share, 1) > 1e-9 * share.max())
    pairs = np.stack([a_idx, b_idx], axis=1).astype(np.int64)
    moments = np.stack([(smooth * rest[:, i, None]).T @ smooth for i in range(3)], axis=-1)  # (B, B, 3)
    centres = moments[a_idx, b_idx] / share[a_idx, b_idx, None]
    rot, trans = transforms[:, :, :3, :3], transforms[:, :, :3, 3]
    da = rot[:, a_idx] - rot[:, b_idx]  # (T, P, 3, 3)
    db = trans[:, a_idx] - trans[:, b_idx]  # (T, P, 3)
    frames = transforms.shape[0]
    stiffness = np.einsum("tpki,tpkj->pij", da, da) / frames
    lhs = frames * (stiffness + pivot_regularisation * np.eye(3))
    rhs = -np.einsum("tpki,tpk->pi", da, db) + pivot_regularisation * frames * centres
    pivots = np.linalg.solve(lhs, rhs[..., None])[..., 0]
    gap = np.einsum("tpij,pj->tpi", da, pivots) + db
    mismatch = np.sqrt((gap**2).sum(-1).mean(0))
    return BonePairs(pairs, pivots, mismatch, share[a_idx, b_idx], centres, stiffness)
