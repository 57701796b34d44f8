"""Surface smoothing of weights: rows stay normalised, and a reach keeps long edges from carrying weight."""

from __future__ import annotations

import numpy as np

from simcore.geometry.laplacian import adjacency
from simcore.skinning.postprocess import smooth_on_surface


def _strip() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Two quads of a strip, 0.1 apart inside each and 1.3 apart between them (a coarse ring mesh's long edge).

    Vertices 0-1 belong to bone 0, 2-5 to bone 1: bone 0's weight reaches 2-3 over short edges and could only
    go on to 4-5 along the long ones."""
    x = np.array([0.0, 0.0, 0.1, 0.1, 1.4, 1.4])
    y = np.array([0.0, 1.0, 0.0, 1.0, 0.0, 1.0])
    vertices = np.column_stack([x, y, np.zeros(6)])
    faces = np.array([[0, 2, 1], [1, 2, 3], [2, 4, 3], [3, 4, 5]])
    weights = np.zeros((6, 2))
    weights[:2, 0] = 1.0
    weights[2:, 1] = 1.0
    return vertices, faces, weights


def test_rows_stay_normalised_with_and_without_reach() -> None:
    vertices, faces, weights = _strip()
    adj = adjacency(faces, len(vertices))
    for reach in (0.0, 0.2):
        smoothed = smooth_on_surface(weights, adj, 8, 0.25, vertices, reach)
        np.testing.assert_allclose(smoothed.sum(axis=1), 1.0, atol=1e-12)
        assert smoothed.min() >= 0.0


def test_reach_keeps_long_edges_from_carrying_weight() -> None:
    vertices, faces, weights = _strip()
    adj = adjacency(faces, len(vertices))
    plain = smooth_on_surface(weights, adj, 8, 0.25)
    reached = smooth_on_surface(weights, adj, 8, 0.25, vertices, reach=0.2)
    far = [4, 5]  # the pair at the end of the 1.3-long edges
    assert plain[far, 0].max() > 0.05  # unweighted by length, bone 0's weight crosses the long edge
    assert reached[far, 0].max() < 0.005  # (0.2 / 1.3)² of the pull: almost nothing crosses
    near = [2, 3]  # 0.1 from bone 0's vertices: within reach, smoothed as before
    np.testing.assert_allclose(reached[near, 0], plain[near, 0], rtol=0.5)
