"""Rigid and similarity fits recover known transforms and never return a reflection."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from simcore.geometry.similarity import point_spread, rigid_fit, rotation_from_covariance, similarity_fit


def test_rigid_fit_recovers_the_weighted_transform() -> None:
    rng = np.random.default_rng(0)
    source = rng.normal(size=(40, 3))
    rot = Rotation.from_rotvec([0.3, -1.1, 0.7]).as_matrix()
    target = source @ rot.T + [1.0, 2.0, -0.5]
    target[30:] += rng.normal(size=(10, 3))  # outliers carry no weight
    weights = np.r_[rng.uniform(0.5, 2.0, 30), np.zeros(10)]
    got_rot, got_t = rigid_fit(source, target, weights)
    assert np.allclose(got_rot, rot, atol=1e-9)
    assert np.allclose(got_t, [1.0, 2.0, -0.5], atol=1e-9)


def test_rigid_fit_without_weight_is_identity() -> None:
    points = np.ones((5, 3))
    rot, t = rigid_fit(points, points + 1.0, np.zeros(5))
    assert np.array_equal(rot, np.eye(3)) and np.array_equal(t, np.zeros(3))


def test_similarity_fit_recovers_scale_rotation_and_shift() -> None:
    rng = np.random.default_rng(1)
    source = rng.normal(size=(25, 3))
    rot = Rotation.from_rotvec([-0.4, 0.2, 2.0]).as_matrix()
    scale, got_rot, shift = similarity_fit(source, 2.5 * source @ rot.T + [0.0, -3.0, 1.0])
    assert np.isclose(scale, 2.5) and np.allclose(got_rot, rot) and np.allclose(shift, [0.0, -3.0, 1.0])


def test_point_spread_is_the_summed_variance() -> None:
    source = np.random.default_rng(3).normal(size=(12, 3))
    assert np.isclose(point_spread(source), np.var(source, axis=0).sum())


def test_mirrored_points_give_a_proper_rotation_batched() -> None:
    rng = np.random.default_rng(2)
    source = rng.normal(size=(3, 20, 3))
    mirrored = source * [-1.0, 1.0, 1.0]
    rots = rotation_from_covariance(np.einsum("bni,bnj->bij", mirrored, source))
    assert rots.shape == (3, 3, 3)
    assert np.allclose(np.linalg.det(rots), 1.0)
    assert np.allclose(rots @ rots.transpose(0, 2, 1), np.eye(3))
