"""Skeleton quality metrics against a ground-truth rig: J2J, J2B, B2B, joint counts, joints inside the mesh.

Protocol (issue 3; the same as /work/shared/tools/rigmetrics.py so figures compare): positions are put in
unit-cube units, the ground-truth mesh's bounding box centred with its longest side 1. Each skeleton
becomes a joint set and a bone point set (its joints plus points on every parent→child segment, spaced
at most 0.005 apart). All three distances are symmetric chamfers, each half the sum of the two mean
nearest-neighbour distances:
  J2J: predicted joints ↔ ground-truth joints;
  J2B: predicted joints → ground-truth bone points and ground-truth joints → predicted bone points;
  B2B: predicted bone points ↔ ground-truth bone points.
J2J splits into extra and misplaced joints: `j2j_matched` is J2J over the predicted joints that are some
ground-truth joint's nearest one only (the others are extra: no artist joint is closest to them); j2j − j2j_matched
is what the extra joints cost, and j2j_matched what joint placement and missing joints cost.
Ground truth = the skin joints that influence a vertex or have a descendant that does, at bind pose.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from scipy.spatial import cKDTree

from simcore.geometry.segments import segment_points
from simcore.geometry.voxelize import JOINT_TEST_RESOLUTION, VoxelGrid, solid_voxels
from simcore.io.gltf_rig import RiggedAsset, used_joints
from simcore.skeleton.tokenizer import Normalization
from simcore.skeleton.types import Skeleton

BONE_STEP = 0.005  # unit-cube units between bone samples


@dataclass
class SkeletonScores:
    """Metric values in unit-cube units; `inside` is the share (0..1) of predicted joints inside the mesh."""

    j2j: float
    j2b: float
    b2b: float
    joints_pred: int
    joints_gt: int
    inside: float
    j2j_matched: float | None = None

    @property
    def joint_ratio(self) -> float:
        """joints_pred / joints_gt."""
        return self.joints_pred / max(self.joints_gt, 1)

    def to_dict(self) -> dict:
        """JSON-ready values (distances rounded to 1e-6), joint_ratio included."""
        out = asdict(self)
        for key in ("j2j", "j2b", "b2b", "inside", "j2j_matched"):
            if out[key] is not None:
                out[key] = round(float(out[key]), 6)
        out["joint_ratio"] = round(self.joint_ratio, 4)
        return out


def unit_cube(vertices: np.ndarray) -> Normalization:
    """Normalisation putting the bounding box of `vertices` (V, 3) at the origin with its longest side 1."""
    half = Normalization.from_points(vertices)
    return Normalization(half.center, 2.0 * half.scale)


def used_skeleton(skeleton: Skeleton, keep: np.ndarray) -> Skeleton:
    """The joints where `keep` (J,) bool is True; every kept joint's ancestors must be kept too."""
    idx = np.flatnonzero(keep)
    remap = -np.ones(skeleton.num_joints, np.int64)
    remap[idx] = np.arange(len(idx))
    parents = np.where(skeleton.parents[idx] >= 0, remap[np.maximum(skeleton.parents[idx], 0)], -1)
    orient = None if skeleton.orientations is None else skeleton.orientations[idx]
    return Skeleton(skeleton.positions[idx], parents, [skeleton.names[i] for i in idx],
                    [skeleton.kinds[i] for i in idx], orient).validate()


def ground_truth_skeleton(asset: RiggedAsset) -> Skeleton:
    """The asset's skin joints that influence vertices (or have a descendant that does), at bind pose."""
    return used_skeleton(asset.skeleton, used_joints(asset.skeleton, asset.weights))


def bone_points(positions: np.ndarray, edges: np.ndarray, step: float = BONE_STEP) -> np.ndarray:
    """(N, 3) the joints (J, 3) followed by points on each bone segment, ends included, at most `step` apart.

    edges: (B, 2) int64 joint index pairs (Skeleton.bones() or any graph's edges).
    """
    positions = np.asarray(positions, dtype=np.float64)
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    if len(edges) == 0:
        return positions
    samples, _ = segment_points(positions[edges[:, 0]], positions[edges[:, 1]], step)
    return np.concatenate([positions, samples])


def _mean_nearest(points: np.ndarray, targets: np.ndarray) -> float:
    return float(cKDTree(targets).query(points)[0].mean())


def chamfer(a: np.ndarray, b: np.ndarray) -> float:
    """Symmetric chamfer distance between point sets a (N, 3) and b (M, 3): half the sum of both means."""
    return 0.5 * (_mean_nearest(a, b) + _mean_nearest(b, a))


def graph_scores(pred_joints: np.ndarray, pred_edges: np.ndarray, gt: Skeleton, vertices: np.ndarray,
                 faces: np.ndarray, *, grid: VoxelGrid | None = None) -> SkeletonScores:
    """Compare any predicted joint graph with the ground truth on the ground-truth mesh.

    pred_joints: (N, 3) float64 and pred_edges: (E, 2) int64, in the mesh's frame (metres).
    gt: the ground-truth skeleton, already restricted to its used joints.
    vertices: (V, 3) float64, faces: (F, 3) int64 the ground-truth mesh (normalisation and inside test).
    grid: a precomputed `solid_voxels(vertices, faces, JOINT_TEST_RESOLUTION)` to share across methods.
    """
    norm = unit_cube(vertices)
    pred_joints = np.asarray(pred_joints, dtype=np.float64).reshape(-1, 3)
    pj, gj = norm.to_unit(pred_joints), norm.to_unit(gt.positions)
    pb, gb = bone_points(pj, pred_edges), bone_points(gj, gt.bones())
    if grid is None:
        grid = solid_voxels(vertices, faces, resolution=JOINT_TEST_RESOLUTION)
    matched = np.unique(cKDTree(pj).query(gj)[1])  # each ground-truth joint's nearest predicted joint
    return SkeletonScores(
        j2j=chamfer(pj, gj),
        j2b=0.5 * (_mean_nearest(pj, gb) + _mean_nearest(gj, pb)),
        b2b=chamfer(pb, gb),
        joints_pred=len(pred_joints),
        joints_gt=gt.num_joints,
        inside=float(grid.inside(pred_joints).mean()),
        j2j_matched=0.5 * (_mean_nearest(pj[matched], gj) + _mean_nearest(gj, pj)),
    )


def skeleton_scores(pred: Skeleton, gt: Skeleton, vertices: np.ndarray, faces: np.ndarray,
                    *, grid: VoxelGrid | None = None) -> SkeletonScores:
    """`graph_scores` for a predicted Skeleton (its parent→child bones)."""
    return graph_scores(pred.positions, pred.bones(), gt, vertices, faces, grid=grid)
