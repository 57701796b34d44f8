"""Least-squares similarity between two point sets (Umeyama): rotation, uniform scale and translation."""

from __future__ import annotations

import numpy as np


def similarity_fit(source: np.ndarray, target: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """(s, R (3, 3), t (3,)) minimising Σ|s R source_i + t - target_i|² (Umeyama); source, target (N, 3).
    A source with no spread gives scale 1."""
    mu_s, mu_t = source.mean(0), target.mean(0)
    a, b = source - mu_s, target - mu_t
    u, sig, vt = np.linalg.svd(b.T @ a / len(a))
    d = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt)) or 1.0])
    rot = u @ d @ vt
    var = float((a ** 2).sum() / len(a))
    scale = float(np.trace(np.diag(sig) @ d) / var) if var > 0 else 1.0
    return scale, rot, mu_t - scale * rot @ mu_s
