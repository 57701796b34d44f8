"""Unsupervised skinning quality: what `auto` compares when no reference weights exist.

Signals: PhysSkin's conditioning metrics of the weight matrix, vertices left without any weight, and how much
the surface stretches under the protocol's random test poses (edge strain, recorded for the report).
`score` = Ω_orth + a penalty per unweighted vertex. Ω_orth (how far the weight columns are from orthogonal,
i.e. how much bones overlap) tracks agreement with artist weights; edge strain under random poses does not,
so it is recorded but does not decide.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.sparse as sp

from simcore.geometry.laplacian import edges
from simcore.metrics.skinning import conditioning, protocol_skin_matrices, unit_cube_frame, weight_stats
from simcore.skeleton.types import Skeleton
from simcore.skinning.lbs import linear_blend

TEST_POSES = 4
UNWEIGHTED_PENALTY = 10.0  # per fraction of vertices: one left behind at the origin outweighs any conditioning gain


def edge_strain(vertices: np.ndarray, faces: np.ndarray, skeleton: Skeleton, weights: sp.csr_matrix, poses: int = TEST_POSES) -> dict[str, float]:
    """Mean and p95 over edges and test poses of |deformed length / rest length − 1| (unit-cube frame).

    vertices: (V, 3), faces: (F, 3) (welded, so seams are edges), weights: (V, J).
    """
    centre, side = unit_cube_frame(vertices)
    v = (vertices - centre) / side
    skel = replace(skeleton, positions=(skeleton.positions - centre) / side, orientations=None)
    e = edges(faces)
    if len(e) == 0:
        return {"strain_mean": 0.0, "strain_p95": 0.0}
    rest = np.linalg.norm(v[e[:, 0]] - v[e[:, 1]], axis=1)
    ok = rest > 1e-9
    e, rest = e[ok], rest[ok]
    posed = linear_blend(v, weights, protocol_skin_matrices(skel, poses, seed=1))  # (T, V, 3)
    length = np.linalg.norm(posed[:, e[:, 0]] - posed[:, e[:, 1]], axis=2)
    strain = np.abs(length / rest - 1.0).ravel()
    return {"strain_mean": float(strain.mean()), "strain_p95": float(np.percentile(strain, 95))}


def quality_scores(vertices: np.ndarray, faces: np.ndarray, skeleton: Skeleton, weights: sp.csr_matrix) -> dict[str, float]:
    """Every unsupervised signal plus `score` (lower is better) combining them; JSON-ready floats."""
    stats = weight_stats(weights)
    out: dict[str, float] = {}
    out.update(edge_strain(vertices, faces, skeleton, weights))
    out.update(conditioning(weights))
    out["unweighted_vertices"] = float(stats["unweighted_vertices"])
    unweighted = stats["unweighted_vertices"] / max(stats["vertices"], 1)
    out["score"] = out["omega_orth"] + UNWEIGHTED_PENALTY * unweighted
    return {k: round(float(v), 6) for k, v in out.items()}
