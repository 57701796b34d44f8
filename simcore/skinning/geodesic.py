"""Geodesic voxel binding (Dionne & de Lasa 2013, the distance UniRig's skinning model consumes).

The mesh is voxelised into a solid (robust to holes and several components). Shortest paths run through
the occupied voxels (26 neighbours, Euclidean steps) from every joint's bone segments, so a distance never
cuts through empty space between the legs or from an arm into the torso. A joint's search starts from the
voxels its segments cross (at the voxel-centre-to-segment distance) and stops where the joint is too far to
matter (CUTOFF); vertices then read the distance of the 8 voxel centres around them. Bulky shapes are
coarsened to MAX_VOXELS.
No relaxation along mesh edges follows the gathers: the voxel paths already follow the surface closely enough.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable

import numpy as np
from scipy.spatial import cKDTree

from simcore.arrays import unique_ints
from simcore.geometry.segments import row_distances, segment_points
from simcore.geometry.voxel_paths import VoxelPaths
from simcore.geometry.voxelize import VoxelGrid, solid_voxels
from simcore.geometry.weld import weld_vertices
from simcore.skeleton.types import Skeleton
from simcore.skinning.bones import JointSegments, joint_distances, joint_segments
from simcore.skinning.postprocess import normalize_rows

ALPHA = 0.5  # Dionne & de Lasa falloff mix between 1/d and 1/d² (the paper's and UniRig's value)
# The paper's falloff (sharpness 1) spreads weight far wider than artists do, who bind most of a limb to one bone
# and blend only near joints; raising it to a power sharpens the blend while keeping its shape.
SHARPNESS = 6.0
MAX_VOXELS = 80_000  # occupied voxels: bounds the shortest-path searches' time and memory on bulky shapes
RESOLUTION = 128  # voxels along the longest side: fine enough to keep thin limbs apart
# Where a joint is over 1.5× as far as a voxel's nearest joint, its weight there is < 1.5^-24 ≈ 6e-5 of the
# nearest's, under top_k's 1e-4 floor: a joint's search stops at such voxels (+ SLACK_VOXELS, so paths that
# skirt the bound are kept).
CUTOFF = 1.5
SLACK_VOXELS = 2.0
DISTANCE_UNIT = 0.003  # × the bounding box's longest side
LEAF_EXTENSION = 1.0  # leaf joints carry real weight (heads, hands): their segment continues the parent bone
_CORNERS = np.array(list(itertools.product((0, 1), repeat=3)), dtype=np.int64)


def _bone_sources(
    grid: VoxelGrid, ijk: np.ndarray, ids: np.ndarray, skeleton: Skeleton, seg: JointSegments
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(joint, voxel id, link length) for the voxels each joint's segments cross (nearest voxel when outside),
    sorted by joint then voxel; the length is the voxel centre's distance to the joint's nearest segment."""
    n, joints = len(ijk), skeleton.num_joints
    points, segment = segment_points(seg.heads, seg.tails, 0.5 * grid.pitch)
    owner = seg.owner[segment]
    vox = grid.index_of(points)
    vid = np.full(len(points), -1, np.int64)
    inside = grid.in_bounds(vox)
    vid[inside] = ids[tuple(vox[inside].T)]
    hit = vid >= 0
    key_parts = [owner[hit] * n + vid[hit]]
    lost = np.setdiff1d(np.arange(joints), owner[hit])
    if len(lost):  # bones outside the solid (thin part, or a joint placed off the mesh): their nearest voxels
        mine = np.isin(owner, lost)
        key_parts.append(owner[mine] * n + cKDTree(grid.centers(ijk)).query(points[mine], k=1)[1])
    keys = unique_ints(np.concatenate(key_parts))
    sj, sv = keys // n, keys % n
    # Each source's distance to the nearest segment of its joint (segments come grouped by joint).
    first = np.searchsorted(seg.owner, np.arange(joints))
    count = np.bincount(seg.owner, minlength=joints)
    centres = grid.centers(ijk[sv])
    sd = np.full(len(sj), np.inf)
    for k in range(int(count.max())):
        rows = np.flatnonzero(count[sj] > k)
        s = first[sj[rows]] + k
        sd[rows] = np.minimum(sd[rows], row_distances(centres[rows], seg.heads[s], seg.tails[s]))
    return sj, sv, sd


def geodesic_distances(
    vertices: np.ndarray,
    faces: np.ndarray,
    skeleton: Skeleton,
    *,
    resolution: int = RESOLUTION,
    leaf_extension: float = LEAF_EXTENSION,
    leaf_parts: bool = True,
    cutoff: float | None = None,
    progress: Callable[[float], None] = lambda fraction: None,
) -> np.ndarray:
    """(V, J) float64 geodesic distance (metres) from each vertex to each joint's bone segments, through the solid.

    vertices: (V, 3) float, faces: (F, 3) int, skeleton: J joints in the same space. Vertices in a part no
    bone reaches (a floating accessory) get their straight-line distances instead of infinity.
    cutoff: when set, a joint's search stops at voxels where it is over `cutoff` × as far as their nearest
    joint (+ SLACK_VOXELS), and such joints read as infinity (for weights, where such joints get nothing
    anyway); None = complete matrix.
    leaf_parts: a leaf joint's segment points into the mesh part nearest to it (bones.leaf_tails); False: it
    continues the parent bone (what the learned model's inputs were trained with).
    progress: called with the fraction done at each checkpoint (it may raise to stop the computation).
    """
    v = np.asarray(vertices, dtype=np.float64)
    welded = weld_vertices(v, faces)
    wv = welded.vertices
    grid = solid_voxels(wv, welded.faces, resolution=resolution)
    occupied = int(grid.occupancy.sum())
    if occupied > MAX_VOXELS:  # bulky shapes: coarsen so the searches' cost stays bounded (volume ∝ resolution³)
        coarser = max(int(resolution * (MAX_VOXELS / occupied) ** (1.0 / 3.0)), 16)
        grid = solid_voxels(wv, welded.faces, resolution=coarser)
    paths = VoxelPaths(grid.occupancy, grid.pitch)
    ijk, ids = paths.ijk, paths.ids
    progress(0.3)
    j = skeleton.num_joints
    segments = joint_segments(skeleton, leaf_extension, wv if leaf_parts else None)
    sj, sv, sd = _bone_sources(grid, ijk, ids, skeleton, segments)
    bound = None
    if cutoff is not None:  # one pass from all joints at once: each voxel's nearest-joint distance bounds the rest
        nearest = paths.distances(np.zeros_like(sj), sv, sd, 1)[:, 0]
        bound = cutoff * nearest + SLACK_VOXELS * grid.pitch
    progress(0.4)
    voxel_dist = paths.distances(sj, sv, sd, j, bound)  # (n, J)
    progress(0.8)
    # Each vertex reads the 8 voxel centres around it (at least its own surface voxel is occupied).
    lower = np.floor((wv - grid.origin) / grid.pitch).astype(np.int64)
    dist = np.full((len(wv), j), np.inf, dtype=np.float32)
    voxel_dist = voxel_dist.astype(np.float32)  # halves the memory traffic of the gathers below
    shape = np.asarray(ids.shape)
    for off in _CORNERS:
        nb = lower + off
        ok = np.all((nb >= 0) & (nb < shape), axis=1)
        vid = np.full(len(wv), -1, np.int64)
        vid[ok] = ids[tuple(nb[ok].T)]
        has = np.flatnonzero(vid >= 0)
        step = np.linalg.norm(wv[has] - grid.centers(nb[has]), axis=1).astype(np.float32)
        dist[has] = np.minimum(dist[has], voxel_dist[vid[has]] + step[:, None])
    dist = dist.astype(np.float64)
    lost = ~np.isfinite(dist).any(axis=1)
    if lost.any():
        dist[lost] = joint_distances(wv[lost], segments, j)
    return dist[welded.index]


def falloff_weights(distances: np.ndarray, scale: float, alpha: float = ALPHA, sharpness: float = SHARPNESS) -> np.ndarray:
    """(V, J) float64 normalised weights w = ((1 / ((1-α) d + α d²))²)^sharpness with d = distance / scale.

    distances: (V, J) float (inf = unreachable → weight 0); `scale` sets the length unit in which the
    1/d (near) and 1/d² (far) terms trade off. sharpness = 1 is Dionne & de Lasa's falloff.
    """
    d = np.maximum(np.asarray(distances, dtype=np.float64) / scale, 1e-6)
    # Work with logs relative to each row's nearest joint: d^(-4·sharpness) would under/overflow.
    log_w = np.where(np.isfinite(d), -2.0 * sharpness * np.log((1.0 - alpha) * d + alpha * d * d), -np.inf)
    log_w -= log_w.max(axis=1, keepdims=True)
    return normalize_rows(np.exp(log_w))


def geodesic_weights(
    vertices: np.ndarray, faces: np.ndarray, skeleton: Skeleton, *, resolution: int = RESOLUTION, leaf_extension: float = LEAF_EXTENSION,
    progress: Callable[[float], None] = lambda fraction: None,
) -> np.ndarray:
    """(V, J) float64 normalised geodesic-voxel-binding weights (distances in unit-cube units × DISTANCE_UNIT)."""
    dist = geodesic_distances(vertices, faces, skeleton, resolution=resolution, leaf_extension=leaf_extension, cutoff=CUTOFF,
                              progress=lambda fraction: progress(0.9 * fraction))
    v = np.asarray(vertices, dtype=np.float64)
    side = max(float((v.max(axis=0) - v.min(axis=0)).max()), 1e-12)
    weights = falloff_weights(dist, DISTANCE_UNIT * side)
    progress(1.0)
    return weights
