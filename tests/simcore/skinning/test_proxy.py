"""Large meshes are skinned on a simplified proxy: the transferred weights stay close to a full-resolution solve."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from simcore.geometry.capsule_creatures import quadruped
from simcore.metrics.skinning import weight_l1
from simcore.skinning import predict, proxy


def test_proxy_weights_match_the_full_solve(monkeypatch: pytest.MonkeyPatch) -> None:
    vertices, faces, skeleton = quadruped(count=16)
    vertices, faces = trimesh.remesh.subdivide(vertices, faces)
    full = predict.compute_weights(vertices, faces, skeleton, method="geodesic")
    monkeypatch.setattr(predict, "PROXY_VERTICES", len(vertices) // 2)
    monkeypatch.setattr(proxy, "PROXY_TARGET", len(vertices) // 4)
    simplified = predict.compute_weights(vertices, faces, skeleton, method="geodesic")
    assert simplified.weights.shape == full.weights.shape
    np.testing.assert_allclose(np.asarray(simplified.weights.sum(axis=1)).ravel(), 1.0, atol=1e-5)
    assert max(np.diff(simplified.weights.indptr)) <= 4
    assert weight_l1(simplified.weights, full.weights) < 0.15
