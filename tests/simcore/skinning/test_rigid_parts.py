"""Separate mesh parts that mostly follow one joint are bound to it alone; spread parts and one-piece meshes keep theirs."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from simcore.geometry.parts import part_labels
from simcore.skinning.parts import bind_rigid_parts

TETRA = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
TETRA_FACES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


def _two_parts() -> tuple[np.ndarray, np.ndarray]:
    return np.vstack([TETRA, TETRA + [3.0, 0.0, 0.0]]), np.vstack([TETRA_FACES, TETRA_FACES + 4])


def test_parts_are_welded_components():
    v, f = _two_parts()
    v = np.vstack([v, v[:1]])  # a seam duplicate of vertex 0, used by one face instead of vertex 0
    f = f.copy()
    f[0, 0] = 8
    labels = part_labels(v, f)
    assert len(set(labels[:4])) == 1 and len(set(labels[4:8])) == 1 and labels[0] != labels[4] and labels[8] == labels[0]


ONE_JOINT_EACH = np.array([[0.2, 0.2, 0.2], [3.2, 0.2, 0.2], [-1.0, 0.0, 0.0]])  # one in each part, one outside


def test_a_part_holding_one_joint_and_mostly_on_one_joint_follows_it_alone():
    v, f = _two_parts()
    dense = np.zeros((8, 3))
    dense[:4] = [[0.9, 0.1, 0.0], [0.6, 0.4, 0.0], [0.5, 0.5, 0.0], [0.7, 0.3, 0.0]]  # 67.5 % on joint 0
    dense[4:] = [[0.4, 0.3, 0.3], [0.2, 0.4, 0.4], [0.3, 0.3, 0.4], [0.4, 0.3, 0.3]]  # at most 35 % on one joint
    out = bind_rigid_parts(v, part_labels(v, f), sp.csr_matrix(dense), ONE_JOINT_EACH).toarray()
    assert np.array_equal(out[:4], np.tile([1.0, 0.0, 0.0], (4, 1)))
    assert np.allclose(out[4:], dense[4:])
    assert np.allclose(out.sum(axis=1), 1.0)


def test_a_one_piece_mesh_keeps_its_weights():
    dense = np.array([[0.9, 0.1], [0.8, 0.2], [0.7, 0.3], [0.9, 0.1]])
    out = bind_rigid_parts(TETRA, part_labels(TETRA, TETRA_FACES), sp.csr_matrix(dense), np.zeros((0, 3)))
    assert np.allclose(out.toarray(), dense)


def test_a_spread_part_with_no_joint_inside_follows_its_main_joint():
    """A piece blended between bones but holding none of their joints cannot bend about one: it is bound to the
    joint it leans on most; the same piece around a joint keeps its blend."""
    v, f = _two_parts()
    dense = np.zeros((8, 3))
    dense[:4] = [[0.9, 0.1, 0.0], [0.6, 0.4, 0.0], [0.5, 0.5, 0.0], [0.7, 0.3, 0.0]]
    dense[4:] = [[0.4, 0.3, 0.3], [0.2, 0.4, 0.4], [0.3, 0.3, 0.4], [0.4, 0.3, 0.3]]  # joint 2 has the most mass
    outside = np.array([[0.2, 0.2, 0.2], [-1.0, 0.0, 0.0], [-2.0, 0.0, 0.0]])  # all three in or beyond the first part
    out = bind_rigid_parts(v, part_labels(v, f), sp.csr_matrix(dense), outside).toarray()
    assert np.array_equal(out[4:], np.tile([0.0, 0.0, 1.0], (4, 1)))
    inside = outside.copy()
    inside[2] = [3.2, 0.2, 0.2]  # a joint inside the second part's box
    kept = bind_rigid_parts(v, part_labels(v, f), sp.csr_matrix(dense), inside).toarray()
    assert np.allclose(kept[4:], dense[4:])


def test_rigid_pieces_are_parts_on_one_joint_alone():
    from simcore.skinning.parts import rigid_piece_vertices

    v, f = _two_parts()
    labels = part_labels(v, f)
    dense = np.zeros((8, 3))
    dense[:4, 1] = 1.0  # the first part rides joint 1 alone
    dense[4:, 0], dense[4, 0], dense[4, 2] = 1.0, 0.6, 0.4  # the second blends at one vertex
    assert rigid_piece_vertices(labels, sp.csr_matrix(dense)).tolist() == [True] * 4 + [False] * 4
    dense[4, 0], dense[4, 2] = 0.0, 1.0  # every vertex single, but on two joints: not one rigid piece
    assert not rigid_piece_vertices(labels, sp.csr_matrix(dense))[4:].any()
    one = np.zeros(4, np.int64)  # a mesh of one part has no separate pieces
    assert not rigid_piece_vertices(one, sp.csr_matrix(np.eye(3)[[1, 1, 1, 1]])).any()


def test_a_part_holding_two_joints_keeps_its_blend():
    """Parts half the mesh's extent (their size decides nothing): one holding a single joint (a wheel) follows the
    joint it leans on; one holding two joints (a body, or a flock's bird, wings and all) keeps its blend, though it
    puts 67.5 % on one of them."""
    v, f = _two_parts()
    dense = np.tile([[0.9, 0.1, 0.0], [0.6, 0.4, 0.0], [0.5, 0.5, 0.0], [0.7, 0.3, 0.0]], (2, 1))
    joints = np.array([[0.2, 0.2, 0.2], [0.3, 0.1, 0.1], [3.2, 0.2, 0.2]])  # two in the first part, one in the second
    out = bind_rigid_parts(v, part_labels(v, f), sp.csr_matrix(dense), joints).toarray()
    assert np.allclose(out[:4], dense[:4])
    assert np.array_equal(out[4:], np.tile([1.0, 0.0, 0.0], (4, 1)))

