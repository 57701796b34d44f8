"""Per-vertex top-k joint influences in the fixed-width form glTF and UsdSkel store."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from simcore.errors import InvalidInput


@dataclass
class Influences:
    """Fixed-width skin influences, strongest first.

    joints:  (V, k) int64 joint indices; unused slots hold 0 with weight 0.
    weights: (V, k) float32, each row summing to 1 in float32 arithmetic (glTF validator tolerance).
    stats:   JSON-ready figures for report.json (truncation loss, vertices given a fallback joint...).
    """

    joints: np.ndarray
    weights: np.ndarray
    stats: dict


def _normalise_float32(w: np.ndarray) -> np.ndarray:
    """(V, k) float64 rows with positive sums → float32 rows whose float64 sum is 1 to ~1 ulp."""
    out = (w / w.sum(axis=1, keepdims=True)).astype(np.float32)
    # Put the rounding residual on the strongest weight so the stored floats themselves sum to 1.
    residual = 1.0 - out.astype(np.float64).sum(axis=1)
    rows = np.arange(len(out))
    out[rows, 0] = (out[rows, 0].astype(np.float64) + residual).astype(np.float32)
    return out


def top_influences(weights: sp.spmatrix, k: int, vertices: np.ndarray | None = None,
                   joint_positions: np.ndarray | None = None) -> Influences:
    """Keep the k largest weights per vertex and renormalise.

    weights:   (V, J) sparse, non-negative.
    k:         influences per vertex (4 or 8).
    vertices, joint_positions: (V, 3) and (J, 3) float; when given, a vertex with no weight at all is
               bound fully to its nearest joint (else to joint 0) and counted in stats.
    """
    w = sp.csr_matrix(weights, dtype=np.float64)
    w.eliminate_zeros()
    v_count, j_count = w.shape
    if w.nnz and (not np.all(np.isfinite(w.data)) or w.data.min() < 0):
        raise InvalidInput("skin weights must be finite and non-negative", code="invalid_weights", field="weights")
    counts = np.diff(w.indptr)
    width = max(int(counts.max(initial=0)), 1)
    dense_w = np.zeros((v_count, width))
    dense_j = np.zeros((v_count, width), np.int64)
    rows = np.repeat(np.arange(v_count), counts)
    slots = np.arange(w.nnz) - np.repeat(w.indptr[:-1], counts)
    dense_w[rows, slots], dense_j[rows, slots] = w.data, w.indices
    order = np.argsort(-dense_w, axis=1, kind="stable")[:, :k]
    top_w = np.take_along_axis(dense_w, order, axis=1)
    top_j = np.take_along_axis(dense_j, order, axis=1)
    if top_w.shape[1] < k:
        pad = k - top_w.shape[1]
        top_w = np.pad(top_w, ((0, 0), (0, pad)))
        top_j = np.pad(top_j, ((0, 0), (0, pad)))
    top_j[top_w <= 0] = 0
    total = dense_w.sum(axis=1)
    kept = top_w.sum(axis=1)
    empty = kept <= 0
    if np.any(empty):
        fallback = np.zeros(int(empty.sum()), np.int64)
        if vertices is not None and joint_positions is not None:
            fallback = cKDTree(joint_positions).query(np.asarray(vertices)[empty])[1].astype(np.int64)
        top_j[empty] = 0
        top_j[empty, 0] = fallback
        top_w[empty] = 0.0
        top_w[empty, 0] = 1.0
    out_w = _normalise_float32(top_w)
    loss = np.where(total > 0, 1.0 - kept / np.maximum(total, 1e-30), 0.0)
    stats = {
        "vertices": int(v_count),
        "joints": int(j_count),
        "max_influences": int(k),
        "influences_mean": round(float(np.mean((out_w > 0).sum(axis=1))), 4) if v_count else 0.0,
        "influences_max_before_truncation": int(counts.max(initial=0)),
        "truncated_vertices": int(np.count_nonzero(counts > k)),
        "truncation_loss_max": round(float(loss.max(initial=0.0)), 6),
        "unweighted_vertices_bound_to_nearest_joint": int(empty.sum()),
        "joints_without_influence": int(j_count - len(np.unique(top_j[out_w > 0]))),
        "sum_error_max": float(np.abs(out_w.astype(np.float64).sum(axis=1) - 1.0).max(initial=0.0)),
    }
    return Influences(top_j, out_w, stats)
