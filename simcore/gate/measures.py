"""Measures the quality gate compares with its thresholds: weights, skeleton, and a deforming mesh against its
bind pose (edge stretch percentiles and enclosed volume, every frame), plus refinement stability.

All figures are dimensionless (ratios, fractions, counts) so one threshold serves every character size.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from simcore.geometry.laplacian import edges
from simcore.geometry.voxelize import JOINT_TEST_RESOLUTION, solid_voxels
from simcore.metrics.skinning import weight_stats
from simcore.mpm.measures import part_volumes, volume_parts
from simcore.skeleton.types import JointKind, Skeleton
from simcore.skinning.bones import closest_on_segments, joint_segments
from simcore.skinning.lbs import linear_blend

STRETCH_PERCENTILES = (1.0, 99.0)  # per frame, over edges: the shortest and longest edges but for outliers
MIN_ENCLOSED = 0.01  # × bounding-box volume: below this the mesh encloses no volume (a sheet) and none is measured
MIN_EDGE = 1e-6  # × model size: shorter rest edges (coincident vertices) have no stretch ratio
ZERO_BONE = 1e-4  # × model size: a bone shorter than this has no direction to rotate about
BLOCK_VALUES = 8_000_000  # frames × vertices posed at once (≈ 190 MB of float64 positions)


def model_size(vertices: np.ndarray) -> float:
    """Largest bounding-box side of (V, 3) vertices, metres (1.0 for a degenerate mesh)."""
    return float(np.ptp(vertices, axis=0).max()) or 1.0


def weight_figures(weights: sp.csr_matrix, referenced: np.ndarray) -> dict[str, float]:
    """Unweighted vertices (among the `referenced` vertex ids (N,) int that faces use), largest |row sum − 1|
    and non-finite weights of (V, J) weights."""
    w = sp.csr_matrix(weights)
    finite = np.isfinite(w.data)
    stats = weight_stats(w[referenced]) if finite.all() else {"unweighted_vertices": 0, "max_row_sum_error": float("inf")}
    return {
        "unweighted_vertices": int(stats["unweighted_vertices"]),
        "max_row_sum_error": float(stats["max_row_sum_error"]),
        "non_finite_weights": int((~finite).sum()),
    }


def skeleton_figures(skeleton: Skeleton, vertices: np.ndarray, faces: np.ndarray) -> dict[str, float]:
    """Share of joints inside the mesh's solid and share of bones shorter than ZERO_BONE × the model size. Helper
    joints (JointKind.HELPER: a root at the file's origin, a kept rig's controls) deform nothing and are not counted
    in the inside share.

    vertices (V, 3), faces (F, 3): the bind mesh, in the skeleton's frame.
    """
    grid = solid_voxels(vertices, faces, resolution=JOINT_TEST_RESOLUTION)
    body = np.array([kind != JointKind.HELPER for kind in skeleton.kinds])
    bones = skeleton.bones()
    length = np.linalg.norm(skeleton.positions[bones[:, 1]] - skeleton.positions[bones[:, 0]], axis=1) if len(bones) else np.zeros(0)
    return {
        "joints_inside": float(grid.inside(skeleton.positions[body]).mean()) if body.any() else 1.0,
        "zero_length_bone_share": float((length < ZERO_BONE * model_size(vertices)).mean()) if len(length) else 0.0,
    }


@dataclass
class DeformationSeries:
    """Per-frame figures of a deforming mesh against its bind pose.

    stretch_low, stretch_high: (T,) the STRETCH_PERCENTILES over edges of deformed / bind edge length.
    volume_ratio: (T,) enclosed volume / bind volume, or None when the bind mesh encloses no volume. The volume
                  is the sum of the surface parts' own (mpm.measures.part_volumes): a closed part's enclosed volume,
                  an open one's cones from its own centroid, so no part's rigid motion changes it (a character of
                  open pieces, such as plates and joint covers, keeps its volume when the pieces move apart).
    """

    stretch_low: np.ndarray
    stretch_high: np.ndarray
    volume_ratio: np.ndarray | None


def measured_edges(rest: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """((E, 2) edges, (E,) bind lengths) of the mesh's edges that have a stretch ratio (longer than MIN_EDGE ×
    the model size)."""
    e = edges(faces)
    rest_len = np.linalg.norm(rest[e[:, 0]] - rest[e[:, 1]], axis=1)
    keep = rest_len > MIN_EDGE * model_size(rest)
    return e[keep], rest_len[keep]


def edge_ratios(frames: np.ndarray, e: np.ndarray, rest_len: np.ndarray) -> np.ndarray:
    """(t, E) posed / bind length of edges `e` in frames (t, V, 3)."""
    d = frames[:, e[:, 0]] - frames[:, e[:, 1]]
    return np.sqrt(np.einsum("tek,tek->te", d, d)) / rest_len


def deformation_series(rest: np.ndarray, faces: np.ndarray, blocks: Iterable[np.ndarray]) -> DeformationSeries:
    """Edge stretch and volume of every frame in `blocks` ((t, V, 3) arrays, in order) against `rest` (V, 3)."""
    rest = np.asarray(rest, np.float64)
    e, rest_len = measured_edges(rest, faces)
    face_parts = volume_parts(rest, faces)
    rest_volume = float(part_volumes(rest, faces, face_parts).sum())
    box = float(np.prod(np.ptp(rest, axis=0)))
    enclosed = abs(rest_volume) > MIN_ENCLOSED * box
    low, high, vol = [], [], []
    for frames in blocks:
        ratio = edge_ratios(frames, e, rest_len)
        p = np.nan_to_num(np.percentile(ratio, STRETCH_PERCENTILES, axis=1), nan=np.inf)  # (2, t)
        low.append(p[0])
        high.append(p[1])
        if enclosed:
            vol.append(part_volumes(frames, faces, face_parts).sum(axis=1) / rest_volume)
    def cat(parts: list[np.ndarray]) -> np.ndarray:
        return np.concatenate(parts) if parts else np.zeros(0)

    return DeformationSeries(cat(low), cat(high), cat(vol) if enclosed else None)


def lbs_blocks(vertices: np.ndarray, weights: sp.csr_matrix, mats: np.ndarray) -> Iterator[np.ndarray]:
    """(t, V, 3) LBS positions of consecutive frames of mats (T, J, 4, 4), a few frames at a time."""
    step = max(1, BLOCK_VALUES // max(len(vertices), 1))
    for start in range(0, len(mats), step):
        yield linear_blend(vertices, weights, mats[start:start + step])


def bone_radii(skeleton: Skeleton, vertices: np.ndarray, weights: sp.csr_matrix) -> np.ndarray:
    """(V,) the flesh radius around each vertex's dominant joint: the median bind distance from that joint's
    bones of the vertices it dominates (a limb's thickness, the scale a torn-off piece is measured in)."""
    seg = joint_segments(skeleton)
    owner = np.asarray(sp.csr_matrix(weights).argmax(axis=1)).ravel()
    dist = np.full(len(vertices), np.inf)
    for j in np.unique(owner):
        mine = owner == j
        d = closest_on_segments(vertices[mine], seg.heads[seg.owner == j], seg.tails[seg.owner == j])[0]
        dist[mine] = d.min(axis=1)
    radius = np.zeros(skeleton.num_joints)
    for j in np.unique(owner):
        radius[j] = float(np.median(dist[owner == j]))
    floor = MIN_EDGE * model_size(vertices)
    return np.maximum(radius[owner], floor)
