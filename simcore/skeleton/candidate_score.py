"""The one quality score of a skeleton that needs no ground truth; `auto` and best-of-N both pick by it.

Terms, lengths relative to the mesh's size (longest side of its bounding box):
- inside: share of joints inside the solid (bones belong in the body);
- medial_gap: mean distance from the solid's medial axis to the nearest bone (a part of the body no bone runs
  through: a skeleton with too few joints);
- off_medial: mean distance from points along the bones to the solid's medial axis (bones that cut across the
  body instead of running along its parts);
- asymmetry: on a mirror-symmetric mesh, the mean distance from each joint's mirror image to the nearest joint;
- stacked: share of bones shorter than 1 % of the size (two joints in one place: an implausible joint count).
The weights were chosen on corpus `train` characters (`rigforge eval skeleton` reports val and dev). Terms that
measured well in isolation but picked worse skeletons there (the reach of the extremities, bones shorter than the
body is thick) are not used: artists end chains at a pivot short of the tip, which reach punishes. The learned
model's best-of-N adds its own mean log-probability per token (`LOG_PROB_WEIGHT`) to break ties between its
samples; `auto` compares methods on `total` alone.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from scipy.spatial import cKDTree

from simcore.geometry.voxelize import JOINT_TEST_RESOLUTION, VoxelGrid, solid_voxels
from simcore.metrics.skeleton import bone_points
from simcore.skeleton.medial import medial_voxels
from simcore.skeleton.mirror import MirrorPlane
from simcore.skeleton.symmetry import body_mirror
from simcore.skeleton.types import SHORT_BONE, Skeleton

WEIGHTS = {"inside": 1.0, "medial_gap": -1.0, "off_medial": -5.0, "asymmetry": -5.0, "stacked": -1.0}
LOG_PROB_WEIGHT = 0.1


@dataclass(frozen=True)
class ShapeContext:
    """What every candidate of one mesh is scored against: its solid, its medial axis (a KD-tree over the medial
    voxel centres), mirror plane (None when the mesh is not mirror-symmetric) and size (metres)."""

    grid: VoxelGrid
    medial: cKDTree
    mirror: MirrorPlane | None
    size: float


def shape_context(vertices: np.ndarray, faces: np.ndarray) -> ShapeContext:
    """The ShapeContext of a mesh (vertices (V, 3) metres, faces (F, 3)); deterministic."""
    grid = solid_voxels(vertices, faces, resolution=JOINT_TEST_RESOLUTION)
    ijk = medial_voxels(grid)[0]
    medial = grid.centers(ijk) if len(ijk) else np.asarray(vertices, dtype=np.float64)
    return ShapeContext(grid, cKDTree(medial), body_mirror(vertices), float(np.ptp(vertices, axis=0).max()))


@dataclass(frozen=True)
class CandidateScore:
    """The terms of the module docstring and their weighted sum `total` (higher is better)."""

    inside: float
    medial_gap: float
    off_medial: float
    asymmetry: float
    stacked: float
    total: float

    def to_dict(self) -> dict:
        return {k: round(v, 5) for k, v in asdict(self).items()}


def score_candidate(skeleton: Skeleton, shape: ShapeContext) -> CandidateScore:
    """Score one candidate (joints in the mesh's frame) against `shape`."""
    joints = skeleton.positions
    bones = skeleton.bones()
    inside = float(shape.grid.inside(joints).mean())
    along = bone_points(joints / shape.size, bones) * shape.size
    medial_gap = float(cKDTree(along).query(shape.medial.data)[0].mean()) / shape.size
    off_medial = float(shape.medial.query(along)[0].mean()) / shape.size
    asymmetry = 0.0
    if shape.mirror is not None:
        asymmetry = float(cKDTree(joints).query(shape.mirror.reflect(joints))[0].mean()) / shape.size
    lengths = np.linalg.norm(joints[bones[:, 1]] - joints[bones[:, 0]], axis=1) if len(bones) else np.zeros(0)
    stacked = float((lengths < SHORT_BONE * shape.size).mean()) if len(lengths) else 1.0
    terms = {"inside": inside, "medial_gap": medial_gap, "off_medial": off_medial, "asymmetry": asymmetry,
             "stacked": stacked}
    return CandidateScore(**terms, total=sum(WEIGHTS[k] * v for k, v in terms.items()))
