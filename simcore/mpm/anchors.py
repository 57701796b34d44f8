"""Per-frame driving-point targets for the inverse fit, posed from the observed frame itself.

Each driving point belongs to a joint (or virtual joint). For every frame, each joint's rigid motion from frame 0
is the weighted Procrustes (Kabsch) fit of the target vertices under that joint's coarse skinning weights; a
driving point's anchor at frame t is its frame-0 position moved by its joint's transform at t. Anchors depend
on frame t alone (as an LBS pose does), so an error at one frame is not carried into the next.
"""

from __future__ import annotations

import numpy as np

from simcore.geometry.similarity import rigid_fits


def joint_motions(targets: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(T, M, 3, 3) rotations and (T, M, 3) translations taking frame 0 to each frame, per joint.

    targets: (T, V, 3) vertex positions; weights: (V, M) coarse skinning weights (columns need not sum to 1).
    Every frame and joint is one weighted Kabsch fit (`rigid_fits`, one batch); a joint whose weights sum to
    about 0 keeps the identity.
    """
    rot = np.tile(np.eye(3), (len(targets), weights.shape[1], 1, 1))
    trans = np.zeros((len(targets), weights.shape[1], 3))
    rot[1:], trans[1:] = rigid_fits(targets[0], targets[1:], weights)  # frame 0 is the identity exactly
    return rot, trans


def falloff_weights(vertices: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """(V, M) Gaussian weights of vertices around virtual-joint centres (M, 3), width the mean centre spacing."""
    from scipy.spatial import cKDTree

    if len(centres) > 1:
        spread = float(cKDTree(centres).query(centres, k=2)[0][:, 1].mean())
    else:
        spread = float(np.linalg.norm(vertices - centres[0], axis=1).max()) or 1.0
    d2 = ((vertices[:, None, :] - centres[None]) ** 2).sum(-1)
    w = np.exp(-d2 / (2 * spread**2))
    return w / np.maximum(w.sum(1, keepdims=True), 1e-12)


def driver_anchors(rot: np.ndarray, trans: np.ndarray, drivers0: np.ndarray, owners: np.ndarray) -> np.ndarray:
    """(T, D, 3) anchor in every frame of each driving point (D, 3) at frame 0, carried by joint owners (D,)
    with the joint motions of `joint_motions` (rot (T, M, 3, 3), trans (T, M, 3))."""
    return np.einsum("tdab,db->tda", rot[:, owners], drivers0) + trans[:, owners]
