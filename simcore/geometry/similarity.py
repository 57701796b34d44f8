"""Least-squares rigid and similarity fits between point sets (Kabsch / Umeyama), from one rotation solve."""

from __future__ import annotations

import numpy as np

MIN_WEIGHT = 1e-6  # weights summing below this give the identity fit


def rotation_from_covariance(cov: np.ndarray) -> np.ndarray:
    """Proper rotations R (..., 3, 3) maximising trace(Rᵀ cov) for cross-covariances cov = Σ target sourceᵀ
    (..., 3, 3): the least-squares rotation taking source points onto target points, reflections excluded."""
    u, _, vt = np.linalg.svd(cov)
    flip = np.sign(np.linalg.det(u @ vt))
    u[..., :, 2] *= np.where(flip == 0, 1.0, flip)[..., None]
    return u @ vt


def rigid_fit(source: np.ndarray, target: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(R (3, 3), t (3,)) minimising Σ w_i |R source_i + t − target_i|²; weights (N,) ≥ 0. Identity when the
    weights sum to about 0."""
    total = float(weights.sum())
    if total < MIN_WEIGHT:
        return np.eye(3), np.zeros(3)
    mu_s = weights @ source / total
    mu_t = weights @ target / total
    rot = rotation_from_covariance(((target - mu_t) * weights[:, None]).T @ (source - mu_s))
    return rot, mu_t - rot @ mu_s


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
