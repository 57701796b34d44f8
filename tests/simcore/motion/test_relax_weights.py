"""Weights relaxed under the clip: a blend a bend crushes is widened, everything else is left bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import torch
from scipy.spatial.transform import Rotation

from simcore.gate.measures import deformation_series, lbs_blocks
from simcore.geometry.laplacian import edges
from simcore.motion.relax_weights import TOLERANCE, VOLUME_TOLERANCE, _Region, _volume_loss, relax_weights
from simcore.skinning.lbs import linear_blend
from tests.simcore.tube_mesh import tube


def _bend(frames: int = 12, degrees: float = 90.0) -> np.ndarray:
    """(T, 3, 4, 4) skinning matrices: joints 1 and 2 turn about z through joint 1's head, up to `degrees`."""
    mats = np.tile(np.eye(4), (frames, 3, 1, 1))
    pivot = np.array([0.0, 1.0, 0.0])
    for t, angle in enumerate(np.radians(np.linspace(0.0, degrees, frames))):
        turn = Rotation.from_rotvec([0.0, 0.0, angle]).as_matrix()
        mats[t, 1:, :3, :3] = turn
        mats[t, 1:, :3, 3] = pivot - turn @ pivot
    return mats


def _step(vertices: np.ndarray) -> sp.csr_matrix:
    """The whole tube handed from joint 0 to joint 1 across the one ring of edges at the joint."""
    w = np.zeros((len(vertices), 3))
    w[vertices[:, 1] < 1.0, 0] = 1.0
    w[vertices[:, 1] >= 1.0, 1] = 1.0
    return sp.csr_matrix(w)


def _tails(vertices: np.ndarray, faces: np.ndarray, weights: sp.csr_matrix, mats: np.ndarray) -> tuple[float, float]:
    series = deformation_series(vertices, faces, lbs_blocks(vertices, weights, mats))
    return float(series.stretch_low.min()), float(series.stretch_high.max())


def test_a_blend_a_bend_crushes_is_widened_and_the_rest_is_untouched() -> None:
    vertices, faces, _ = tube(rings=21)
    weights, mats = _step(vertices), _bend()
    low, high = _tails(vertices, faces, weights, mats)
    out = relax_weights(vertices, faces, weights, mats)
    new_low, new_high = _tails(vertices, faces, out.weights, mats)
    worst, new_worst = max(1.0 - low, high - 1.0), max(1.0 - new_low, new_high - 1.0)
    assert worst > 1.0 and new_worst < 0.7 * worst  # the outer side of the bend stretched to over twice its length
    assert new_low >= low  # and nothing traded that for crushing the inner side
    assert out.vertices_moved > 0 and out.mean_row_change > 0.05
    w = out.weights.toarray()
    np.testing.assert_allclose(w.sum(axis=1), 1.0, atol=1e-5)
    assert w.min() >= 0.0 and np.all(w[:, 2] == 0.0)  # no joint enters where none had weight
    far = np.abs(vertices[:, 1] - 1.0) > 0.5  # more than two rings from the joint's ring
    assert np.array_equal(w[far], weights.toarray()[far].astype(np.float32))


def test_a_clip_that_deforms_nothing_changes_no_weight() -> None:
    vertices, faces, _ = tube(rings=11)
    weights = _step(vertices)
    out = relax_weights(vertices, faces, weights, np.tile(np.eye(4), (5, 3, 1, 1)))
    assert out.vertices_moved == 0 and out.edges_over == 0
    assert np.array_equal(out.weights.toarray(), weights.toarray())


def test_a_gentle_blend_within_the_tolerance_is_left_alone() -> None:
    vertices, faces, _ = tube(rings=21)
    weights, mats = _step(vertices), _bend(degrees=0.5)
    low, high = _tails(vertices, faces, weights, mats)
    assert 1.0 + 1e-4 < high < 1.0 + TOLERANCE and 1.0 - TOLERANCE < low  # the edges do bend, within the tolerance
    out = relax_weights(vertices, faces, weights, mats)
    assert out.vertices_moved == 0
    assert np.array_equal(out.weights.toarray(), weights.toarray())


def test_seam_copies_of_a_vertex_keep_one_row() -> None:
    vertices, faces, _ = tube(rings=21)
    seam = np.flatnonzero(np.isclose(vertices[:, 0], 0.2) & np.isclose(vertices[:, 2], 0.0))  # angle 0: one column
    copies = len(vertices) + np.arange(len(seam))
    vertices = np.vstack([vertices, vertices[seam]])  # the seam's faces on one side use the copies (a UV seam)
    remap = np.arange(len(vertices))
    remap[seam] = copies
    side = vertices[faces].mean(axis=1)[:, 2] < 0
    faces = np.where(side[:, None], remap[faces], faces)
    weights = _step(vertices)  # the copies lie where their originals do: same rows
    out = relax_weights(vertices, faces, weights, _bend()).weights.toarray()
    assert not np.allclose(out[seam], weights.toarray()[seam])  # the seam runs across the bend: it moved
    np.testing.assert_array_equal(out[seam], out[copies])


def test_the_volume_term_reads_the_gates_volume_on_the_region_it_moves() -> None:
    """The loss's volume of each frame, built from the moving region alone, is the quality gate's volume."""
    vertices, faces, _ = tube(rings=21)
    weights, mats = _step(vertices), _bend()
    e = edges(faces)
    rest = np.linalg.norm(vertices[e[:, 0]] - vertices[e[:, 1]], axis=1)
    moving = np.abs(vertices[:, 1] - 1.0) < 0.25
    rows = np.flatnonzero(moving)
    region = _Region.around(moving, rows, e, rest, faces)
    loss = _volume_loss(vertices, faces, weights, mats, region)
    assert loss is not None
    posed = linear_blend(vertices, weights, mats)[:, region.ends].transpose(1, 0, 2)  # vertex-major, as the descent
    ratio = deformation_series(vertices, faces, lbs_blocks(vertices, weights, mats)).volume_ratio
    assert ratio is not None and ratio.max() > 1.0 + VOLUME_TOLERANCE  # the bend changes the tube's volume
    expected = np.mean(np.maximum(np.abs(ratio - 1.0) - VOLUME_TOLERANCE, 0.0) ** 2)
    assert float(loss(torch.from_numpy(posed.astype(np.float32)))) == pytest.approx(expected, rel=1e-3)
