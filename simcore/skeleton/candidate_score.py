"""How good a candidate skeleton looks without ground truth (best-of-N selection of the learned model).

Terms, all relative to the mesh's size (longest side of its bounding box):
- inside: share of joints inside the solid (bones belong in the body);
- reach: mean distance to the nearest bone of the worst-covered 10 % of surface points (the extremities a
  skeleton misses: a limb without a bone leaves its tip far from every bone);
- asymmetry: on a mirror-symmetric mesh, the mean distance from each joint's mirror image to the nearest joint;
- stacked: share of bones shorter than 1 % of the size (two joints in one place: an implausible joint count);
- log_prob: the model's mean log-probability per token (its own confidence).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from scipy.spatial import cKDTree

from simcore.geometry.voxelize import VoxelGrid
from simcore.metrics.skeleton import bone_points
from simcore.skeleton.mirror import MirrorPlane
from simcore.skeleton.types import Skeleton

WEIGHTS = {"inside": 1.0, "reach": -5.0, "asymmetry": -5.0, "stacked": -1.0, "log_prob": 0.1}
WORST_SHARE = 0.1
SHORT_BONE = 0.01


@dataclass(frozen=True)
class ShapeContext:
    """What every candidate of one mesh is scored against: its solid, surface samples (S, 3), mirror plane
    (None when the mesh is not mirror-symmetric) and size (metres)."""

    grid: VoxelGrid
    surface: np.ndarray
    mirror: MirrorPlane | None
    size: float


@dataclass(frozen=True)
class CandidateScore:
    """The terms of the module docstring and their weighted sum `total` (higher is better)."""

    inside: float
    reach: float
    asymmetry: float
    stacked: float
    log_prob: float
    total: float

    def to_dict(self) -> dict:
        return {k: round(v, 5) for k, v in asdict(self).items()}


def score_candidate(skeleton: Skeleton, shape: ShapeContext, log_prob: float) -> CandidateScore:
    """Score one candidate (joints in the mesh's frame) against `shape`."""
    joints = skeleton.positions
    bones = skeleton.bones()
    inside = float(shape.grid.inside(joints).mean())
    along = bone_points(joints / shape.size, bones) * shape.size
    gap = np.sort(cKDTree(along).query(shape.surface)[0])
    reach = float(gap[-max(1, int(WORST_SHARE * len(gap))):].mean()) / shape.size
    asymmetry = 0.0
    if shape.mirror is not None:
        asymmetry = float(cKDTree(joints).query(shape.mirror.reflect(joints))[0].mean()) / shape.size
    lengths = np.linalg.norm(joints[bones[:, 1]] - joints[bones[:, 0]], axis=1) if len(bones) else np.zeros(0)
    stacked = float((lengths < SHORT_BONE * shape.size).mean()) if len(lengths) else 1.0
    terms = {"inside": inside, "reach": reach, "asymmetry": asymmetry, "stacked": stacked, "log_prob": log_prob}
    total = sum(WEIGHTS[k] * v for k, v in terms.items())
    return CandidateScore(**terms, total=total)
