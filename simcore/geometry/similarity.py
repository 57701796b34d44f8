"""Least-squares rigid and similarity fits between point sets (Kabsch / Umeyama), from one rotation solve."""

from __future__ import annotations

import numpy as np

MIN_WEIGHT = 1e-6  # weights summing below this give the identity fit


def rotation_from_covariance(cov: np.ndarray) -> np.ndarray:
    """Proper rotations R (..., 3, 3) maximising trace(Rᵀ cov) for cross-covariances cov = Σ target sourceᵀ
    (..., 3, 3): the least-squares rotation taking source points onto target points, reflections excluded. Given
    any matrices instead (a joint's world frame with scale or a mirror), it is their nearest proper rotation."""
    u, _, vt = np.linalg.svd(cov)
    flip = np.sign(np.linalg.det(u @ vt))
    u[..., :, 2] *= np.where(flip == 0, 1.0, flip)[..., None]
    return u @ vt


def rigid_fits(source: np.ndarray, targets: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(T, L, 3, 3) rotations and (T, L, 3) translations: for every target frame (T, N, 3) and weight column
    (N, L) ≥ 0, the R, t minimising Σ w_i |R source_i + t − target_i|², all in one batch. A column whose
    weights sum to about 0 gives the identity."""
    rot = np.tile(np.eye(3), (len(targets), weights.shape[1], 1, 1))
    trans = np.zeros((len(targets), weights.shape[1], 3))
    totals = weights.sum(0)
    live = np.flatnonzero(totals >= MIN_WEIGHT)
    if not len(live) or not len(targets):
        return rot, trans
    w, total = weights[:, live], totals[live, None]
    mu_s = w.T @ source / total  # (L, 3)
    frame_mean = targets.mean(1, keepdims=True)  # (T, 1, 3): centring first keeps the covariance exact
    moved = targets - frame_mean
    mu_t = np.einsum("vl,tvi->tli", w, moved, optimize=True) / total  # (T, L, 3)
    weighted_source = w.T[:, :, None] * (source[None] - mu_s[:, None])  # (L, N, 3)
    rot[:, live] = rotation_from_covariance(np.einsum("tvi,lvj->tlij", moved, weighted_source, optimize=True))
    trans[:, live] = mu_t + frame_mean - np.einsum("tlij,lj->tli", rot[:, live], mu_s)
    return rot, trans


def rigid_fit(source: np.ndarray, target: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(R (3, 3), t (3,)) minimising Σ w_i |R source_i + t − target_i|²; weights (N,) ≥ 0. Identity when the
    weights sum to about 0. One fit of `rigid_fits`."""
    rot, trans = rigid_fits(source, target[None], weights[:, None])
    return rot[0, 0], trans[0, 0]


def point_spread(points: np.ndarray) -> float:
    """Mean squared distance of points (N, 3) from their centroid."""
    return float(((points - points.mean(0)) ** 2).sum() / len(points))


def similarity_fit(source: np.ndarray, target: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """(s, R (3, 3), t (3,)) minimising Σ|s R source_i + t - target_i|² (Umeyama); source, target (N, 3).
    A source with no spread (`point_spread` 0) gives scale 1."""
    mu_s, mu_t = source.mean(0), target.mean(0)
    a, b = source - mu_s, target - mu_t
    cov = b.T @ a / len(a)
    rot = rotation_from_covariance(cov)
    var = point_spread(source)
    scale = float(np.trace(rot.T @ cov) / var) if var > 0 else 1.0
    return scale, rot, mu_t - scale * rot @ mu_s
