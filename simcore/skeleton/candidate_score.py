"""The one quality score of a skeleton that needs no ground truth; `auto` and best-of-N both pick by it.

Terms, lengths relative to the mesh's size (longest side of its bounding box):
- inside: share of joints inside the solid (bones belong in the body);
- reach: mean distance to the nearest bone of the worst-covered 10 % of surface points (the extremities a
  skeleton misses: a limb without a bone leaves its tip far from every bone);
- medial_gap: mean distance from the solid's medial axis to the nearest bone (a part of the body no bone runs
  through);
- off_medial: mean distance from points along the bones to the medial axis (bones that cut across the body
  instead of running along its parts);
- asymmetry: on a mirror-symmetric mesh, the mean distance from each joint's mirror image to the nearest joint;
- stacked: share of bones shorter than 1 % of the size (two joints in one place: an implausible joint count);
- short: share of bones shorter than the body is thick where they run (the medial radius there): such a
  segment cannot bend the surface around it on its own, so its joint is one too many.
The learned model's best-of-N adds its own mean log-probability per token (`LOG_PROB_WEIGHT`) to break ties
between its samples; `auto` compares methods on `total` alone.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from scipy.spatial import cKDTree

from simcore.geometry.voxelize import VoxelGrid, solid_voxels
from simcore.metrics.skeleton import bone_points
from simcore.skeleton.medial import medial_voxels
from simcore.skeleton.mirror import MirrorPlane
from simcore.skeleton.shape_points import surface_points
from simcore.skeleton.symmetry import body_mirror
from simcore.skeleton.types import Skeleton

WEIGHTS = {"inside": 1.0, "reach": -5.0, "medial_gap": 0.0, "off_medial": 0.0, "asymmetry": -5.0, "stacked": -1.0,
           "short": 0.0}
LOG_PROB_WEIGHT = 0.1
WORST_SHARE = 0.1
SHORT_BONE = 0.01
SURFACE_SAMPLES = 3000  # surface points the reach term is measured on
SOLID_RESOLUTION = 128  # voxels along the longest side of the solid the inside and medial terms use


@dataclass(frozen=True)
class ShapeContext:
    """What every candidate of one mesh is scored against: its solid, surface samples (S, 3), medial-axis voxel
    centres (M, 3) and their radii (M,), mirror plane (None when the mesh is not mirror-symmetric) and size
    (metres)."""

    grid: VoxelGrid
    surface: np.ndarray
    medial: np.ndarray
    medial_radius: np.ndarray
    mirror: MirrorPlane | None
    size: float


def shape_context(vertices: np.ndarray, faces: np.ndarray, seed: int = 0) -> ShapeContext:
    """The ShapeContext of a mesh (vertices (V, 3) metres, faces (F, 3)); deterministic for a `seed`."""
    grid = solid_voxels(vertices, faces, resolution=SOLID_RESOLUTION)
    ijk, radius, _ = medial_voxels(grid)
    surface = surface_points(vertices, faces, SURFACE_SAMPLES, np.random.default_rng(seed))[0]
    medial, radius = (grid.centers(ijk), radius) if len(ijk) else (surface, np.zeros(len(surface)))
    return ShapeContext(grid, surface, medial, radius, body_mirror(vertices), float(np.ptp(vertices, axis=0).max()))


@dataclass(frozen=True)
class CandidateScore:
    """The terms of the module docstring and their weighted sum `total` (higher is better)."""

    inside: float
    reach: float
    medial_gap: float
    off_medial: float
    asymmetry: float
    stacked: float
    short: float
    total: float

    def to_dict(self) -> dict:
        return {k: round(v, 5) for k, v in asdict(self).items()}


def score_candidate(skeleton: Skeleton, shape: ShapeContext) -> CandidateScore:
    """Score one candidate (joints in the mesh's frame) against `shape`."""
    joints = skeleton.positions
    bones = skeleton.bones()
    inside = float(shape.grid.inside(joints).mean())
    along = bone_points(joints / shape.size, bones) * shape.size
    gap = np.sort(cKDTree(along).query(shape.surface)[0])
    reach = float(gap[-max(1, int(WORST_SHARE * len(gap))):].mean()) / shape.size
    medial_gap = float(cKDTree(along).query(shape.medial)[0].mean()) / shape.size
    off_medial = float(cKDTree(shape.medial).query(along)[0].mean()) / shape.size
    asymmetry = 0.0
    if shape.mirror is not None:
        asymmetry = float(cKDTree(joints).query(shape.mirror.reflect(joints))[0].mean()) / shape.size
    lengths = np.linalg.norm(joints[bones[:, 1]] - joints[bones[:, 0]], axis=1) if len(bones) else np.zeros(0)
    stacked = float((lengths < SHORT_BONE * shape.size).mean()) if len(lengths) else 1.0
    short = 1.0
    if len(bones):
        middle = 0.5 * (joints[bones[:, 0]] + joints[bones[:, 1]])
        short = float((lengths < shape.medial_radius[cKDTree(shape.medial).query(middle)[1]]).mean())
    terms = {"inside": inside, "reach": reach, "medial_gap": medial_gap, "off_medial": off_medial,
             "asymmetry": asymmetry, "stacked": stacked, "short": short}
    return CandidateScore(**terms, total=sum(WEIGHTS[k] * v for k, v in terms.items()))
