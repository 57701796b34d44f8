"""Skinning quality metrics: agreement with reference weights, the deformation protocol, PhysSkin's
conditioning metrics, and weight statistics.

Deformation protocol (issue 4, identical to /work/shared/tools/rigmetrics.py so figures compare):
vertices and joints are normalised by the ground-truth mesh's bounding box (centred, longest side 1);
8 poses from one `default_rng(seed)`; in each, every joint (all J, used or not) rotates about its bind
position by a rotation vector with components uniform in ±45°/√3, rest local translations are child −
parent bind positions (axis-aligned joint frames); LBS with reference vs predicted weights; mean and
95th percentile of the vertex distances over all poses.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.sparse as sp

from simcore.skeleton.kinematics import global_transforms, random_pose_locals, skinning_matrices
from simcore.skeleton.types import Skeleton
from simcore.skinning.lbs import linear_blend

POSES = 8
SEED = 0


def _dense(weights: sp.spmatrix | np.ndarray) -> np.ndarray:
    return np.asarray(weights, dtype=np.float64) if isinstance(weights, np.ndarray) else weights.toarray()


def _row_normalised(weights: sp.spmatrix | np.ndarray) -> np.ndarray:
    w = _dense(weights).astype(np.float64)
    return w / np.maximum(w.sum(axis=1, keepdims=True), 1e-12)


def weight_l1(pred: sp.spmatrix | np.ndarray, ref: sp.spmatrix | np.ndarray) -> float:
    """Mean over vertices of Σ_j |w_pred − w_ref| (rows normalised first); both (V, J) on the same joints."""
    return float(np.abs(_row_normalised(pred) - _row_normalised(ref)).sum(axis=1).mean())


def support_precision_recall(pred: sp.spmatrix | np.ndarray, ref: sp.spmatrix | np.ndarray, eps: float = 1e-4) -> tuple[float, float]:
    """Precision and recall of the (vertex, joint) pairs with weight > eps: predicted support vs reference support."""
    p, r = _row_normalised(pred) > eps, _row_normalised(ref) > eps
    both = float(np.logical_and(p, r).sum())
    return both / max(float(p.sum()), 1.0), both / max(float(r.sum()), 1.0)


def unit_cube_frame(vertices: np.ndarray) -> tuple[np.ndarray, float]:
    """(centre (3,), longest side) of the bounding box of vertices (V, 3): x ↦ (x − centre) / side."""
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    return (lo + hi) / 2.0, max(float((hi - lo).max()), 1e-12)


def protocol_skin_matrices(skeleton: Skeleton, poses: int = POSES, seed: int = SEED) -> np.ndarray:
    """(poses, J, 4, 4) skinning matrices of the seeded random poses (axis-aligned joint frames)."""
    axis_aligned = replace(skeleton, orientations=None)
    rng = np.random.default_rng(seed)
    local = np.stack([random_pose_locals(axis_aligned, rng) for _ in range(poses)])
    return skinning_matrices(axis_aligned, global_transforms(axis_aligned, local))


def deformation_error(
    vertices: np.ndarray,
    skeleton: Skeleton,
    pred: sp.spmatrix | np.ndarray,
    ref: sp.spmatrix | np.ndarray,
    *,
    skin_matrices: np.ndarray | None = None,
    poses: int = POSES,
    seed: int = SEED,
) -> dict[str, float]:
    """Mean and p95 vertex distance (unit-cube units of `vertices`) between LBS with `ref` and with `pred`.

    vertices: (V, 3) bind pose; skeleton: J joints in the same space; weights (V, J). `skin_matrices`
    (T, J, 4, 4), already in unit-cube space, replaces the random protocol poses (e.g. an asset's clips).
    """
    centre, side = unit_cube_frame(vertices)
    v = (vertices - centre) / side
    if skin_matrices is None:
        norm = replace(skeleton, positions=(skeleton.positions - centre) / side, orientations=None)
        skin_matrices = protocol_skin_matrices(norm, poses, seed)
    a = linear_blend(v, sp.csr_matrix(_row_normalised(ref)), skin_matrices)
    b = linear_blend(v, sp.csr_matrix(_row_normalised(pred)), skin_matrices)
    err = np.linalg.norm(a - b, axis=-1).ravel()
    return {"deform_mean": float(err.mean()), "deform_p95": float(np.percentile(err, 95))}


def conditioning(weights: sp.spmatrix | np.ndarray) -> dict[str, float]:
    """PhysSkin metrics of a (V, K) weight matrix, columns ℓ2-normalised to Ŵ (all-zero columns left out).

    omega_orth = ‖ŴᵀŴ − I‖²_F / (K(K−1)) (lower = more independent bones), kappa_log = log2(1 + λmax/λmin)
    of ŴᵀŴ (lower = better conditioned; λmin floored at 1e-12), h_spec = −Σ pᵢ log pᵢ / log K with
    pᵢ = λᵢ / Σλ (higher = energy spread over more modes).
    """
    w = _dense(weights)
    norms = np.linalg.norm(w, axis=0)
    w = w[:, norms > 0] / norms[norms > 0]
    k = w.shape[1]
    if k < 2:
        return {"omega_orth": 0.0, "kappa_log": 1.0, "h_spec": 0.0}
    gram = w.T @ w
    omega = float(((gram - np.eye(k)) ** 2).sum() / (k * (k - 1)))
    lam = np.clip(np.linalg.eigvalsh(gram), 0.0, None)
    kappa = float(np.log2(1.0 + lam.max() / max(lam.min(), 1e-12)))
    p = lam / lam.sum()
    p = p[p > 0]
    h = float(-(p * np.log(p)).sum() / np.log(k))
    return {"omega_orth": omega, "kappa_log": kappa, "h_spec": h}


def weight_stats(weights: sp.spmatrix) -> dict[str, float | int]:
    """Per-vertex influence statistics of (V, J) weights: unweighted vertices, max/mean influences, row-sum error."""
    w = sp.csr_matrix(weights)
    w.eliminate_zeros()
    counts = np.diff(w.indptr)
    sums = np.asarray(w.sum(axis=1)).ravel()
    used = np.asarray((w > 0).sum(axis=0)).ravel() > 0
    return {
        "vertices": int(w.shape[0]),
        "joints": int(w.shape[1]),
        "joints_used": int(used.sum()),
        "unweighted_vertices": int((counts == 0).sum()),
        "max_influences": int(counts.max()) if len(counts) else 0,
        "mean_influences": float(counts.mean()) if len(counts) else 0.0,
        "max_row_sum_error": float(np.abs(sums[counts > 0] - 1.0).max()) if (counts > 0).any() else 0.0,
    }
