"""Steepness limiting: a blend squeezed into one ring of edges is spread until a bend cannot crush those edges."""

from __future__ import annotations

import numpy as np

from simcore.skeleton.types import Skeleton
from simcore.skinning.predict import compute_weights
from simcore.skinning.steepness import STEEPNESS_CAP, EdgeSteepness, limit_steepness, mesh_edges
from tests.simcore.tube_mesh import RADIUS
from tests.simcore.tube_mesh import tube as _tube


def _step(vertices: np.ndarray) -> np.ndarray:
    """(V, 3) weights handing the whole tube from joint 0 to joint 1 across one ring of edges at the joint."""
    weights = np.zeros((len(vertices), 3))
    weights[vertices[:, 1] < 1.0, 0] = 1.0
    weights[vertices[:, 1] >= 1.0, 1] = 1.0
    return weights


def _steepest(vertices: np.ndarray, faces: np.ndarray, skeleton: Skeleton, weights: np.ndarray) -> float:
    a, b = mesh_edges(faces, vertices)
    return float(EdgeSteepness(vertices, a, b, skeleton).of(weights, np.arange(len(a))).max())


def test_a_blend_in_one_ring_is_spread_to_the_cap_with_rows_kept() -> None:
    vertices, faces, skeleton = _tube()
    weights = _step(vertices)
    assert _steepest(vertices, faces, skeleton, weights) > 3.0  # Δ 1 over 0.05, 0.2 from the joint
    limited = limit_steepness(weights, faces, vertices, skeleton)
    assert _steepest(vertices, faces, skeleton, limited) <= STEEPNESS_CAP * 1.2  # relaxed towards the cap in 30 passes
    np.testing.assert_allclose(limited.sum(axis=1), 1.0, atol=1e-12)
    assert limited.min() >= 0.0
    assert np.all(limited[:, 2] == 0.0)  # nothing reaches a joint that held no weight nearby
    # the blend now straddles the joint, wider than one ring, and the ends of the tube stay on their bones
    share = limited[:, 1]
    assert 0.2 < share[np.isclose(vertices[:, 1], 1.0)].mean() < 0.8
    assert np.all(share[vertices[:, 1] < 0.5] == 0.0) and np.all(share[vertices[:, 1] > 1.5] == 1.0)


def test_weights_gentle_enough_are_left_as_they_are() -> None:
    vertices, faces, skeleton = _tube()
    ramp = np.clip(vertices[:, 1] / 2.0, 0.0, 1.0)  # the blend spread over the whole tube
    weights = np.column_stack([1.0 - ramp, ramp, np.zeros(len(vertices))])
    assert _steepest(vertices, faces, skeleton, weights) < STEEPNESS_CAP
    limited = limit_steepness(weights, faces, vertices, skeleton)
    np.testing.assert_array_equal(limited, weights)


def test_steepness_is_measured_from_the_turning_joint_not_the_nearest() -> None:
    """An edge next to the root handing weight from the root to its child bends about the child's head."""
    vertices = np.array([[RADIUS, 0.0, 0.0], [RADIUS, 0.1, 0.0]])
    skeleton = Skeleton(np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0]]), np.array([-1, 0]), ["a", "b"])
    weights = np.array([[1.0, 0.0], [0.5, 0.5]])
    measured = EdgeSteepness(vertices, np.array([0]), np.array([1]), skeleton).of(weights, np.array([0]))[0]
    r_child = np.hypot(RADIUS, 0.95)  # from the edge's middle to joint 1's head
    np.testing.assert_allclose(measured, 0.5 * 1.0 * r_child / 0.1)


def test_every_method_ends_no_steeper_than_the_cap_on_a_coarse_tube() -> None:
    """Nine rings 0.25 apart: the learned model hands the tube from one bone to the next within about one ring
    (steepness near 1 without the limit), which a bend at the joint would crush."""
    vertices, faces, skeleton = _tube(rings=9)
    for method in ("learned", "geodesic", "heat"):
        weights = compute_weights(vertices, faces, skeleton, method=method, root_deforms=True).weights.toarray()
        assert _steepest(vertices, faces, skeleton, weights) <= STEEPNESS_CAP * 1.05, method
