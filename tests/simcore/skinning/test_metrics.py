"""Skinning metrics against hand-computed cases."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.spatial.transform import Rotation

from simcore.metrics.skinning import conditioning, deformation_error, support_precision_recall, weight_l1, weight_stats
from simcore.skeleton.types import Skeleton


def test_l1_and_support_on_hand_cases() -> None:
    ref = np.array([[1.0, 0.0, 0.0], [0.5, 0.5, 0.0]])
    pred = np.array([[0.0, 1.0, 0.0], [0.5, 0.25, 0.25]])
    assert weight_l1(ref, ref) == 0.0
    assert np.isclose(weight_l1(pred, ref), (2.0 + 0.5) / 2)
    precision, recall = support_precision_recall(pred, ref)
    # pred support {(0,1),(1,0),(1,1),(1,2)}, ref support {(0,0),(1,0),(1,1)}: 2 shared.
    assert np.isclose(precision, 2 / 4) and np.isclose(recall, 2 / 3)


def test_conditioning_of_disjoint_and_duplicated_columns() -> None:
    disjoint = np.kron(np.eye(3), np.ones((4, 1)))  # 12 vertices, each on exactly one of 3 bones
    m = conditioning(disjoint)
    assert np.isclose(m["omega_orth"], 0.0) and np.isclose(m["kappa_log"], 1.0) and np.isclose(m["h_spec"], 1.0)
    same = np.ones((5, 2))  # two identical columns: cos = 1 off the diagonal, rank one
    m = conditioning(same)
    assert np.isclose(m["omega_orth"], 1.0) and m["kappa_log"] > 30 and np.isclose(m["h_spec"], 0.0, atol=1e-9)


def test_deformation_protocol_matches_a_two_joint_hand_computation() -> None:
    """Root at x=0, child at x=1, vertex at x=2 bound to the child (ref) or to the root (pred).

    Only the child's own rotation R1 separates the two: |R1 e_x − e_x| × 1 m, in unit-cube units (box side 2).
    """
    skeleton = Skeleton(np.array([[0.0, 0, 0], [1.0, 0, 0]]), np.array([-1, 0]), ["root", "child"])
    vertices = np.array([[0.0, 0, 0], [2.0, 0, 0]])
    ref = sp.csr_matrix(np.array([[1.0, 0.0], [0.0, 1.0]]))
    pred = sp.csr_matrix(np.array([[1.0, 0.0], [1.0, 0.0]]))
    rng = np.random.default_rng(0)
    expected: list[float] = []
    for _ in range(8):
        rotvec = rng.uniform(-1, 1, (2, 3)) * np.deg2rad(45) / np.sqrt(3)
        expected += [0.0, float(np.linalg.norm(Rotation.from_rotvec(rotvec[1]).apply([1.0, 0, 0]) - [1.0, 0, 0])) / 2.0]
    got = deformation_error(vertices, skeleton, pred, ref)
    assert np.isclose(got["deform_mean"], np.mean(expected))
    assert np.isclose(got["deform_p95"], np.percentile(expected, 95))
    assert deformation_error(vertices, skeleton, ref, ref)["deform_mean"] == 0.0


def test_weight_stats_counts_unweighted_vertices_and_influences() -> None:
    w = sp.csr_matrix(np.array([[0.5, 0.5, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]))
    stats = weight_stats(w)
    assert stats["unweighted_vertices"] == 1 and stats["max_influences"] == 2 and stats["joints_used"] == 2
