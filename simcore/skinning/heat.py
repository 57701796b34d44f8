"""Bone heat weights (Baran & Popović 2007, "Pinocchio"), heated as Blender's automatic weights heat them.

Each joint's weight is the equilibrium temperature of the surface when that joint's bones are heated:
(−L + H) w_j = H p_j, with L the cotangent Laplacian (welded mesh, area-weighted). As in Blender's bone heat,
a vertex's distance to a bone is stretched when its normal faces away from it (d / (½ (cos + 1.001)), cos between
the outward normal and the bone-to-vertex direction), the nearest bone by that distance heats the vertex only if the
vertex can *see* it (the straight line to it stays inside the solid voxelisation), H_ii = n_i c / d_i² for the
n_i joints whose bones tie nearest, p_ij = 1 / n_i for each of them, and a vertex that sees none is not
heated: its weights come from its neighbours'. A surface part with no heated vertex at all is heated by its
nearest bones regardless (Blender fails there: "failed to find solution"). Results under 0.05 fade out to
nothing at 0.025 (Blender's weight limit). Duplicate (seam, flat-shaded) vertices are welded first; otherwise
every triangle is its own island and the diffusion does nothing, which is why Blender needs "merge by
distance" on such meshes. One sparse LU factorisation serves all joints.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp
import trimesh
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import splu

from simcore.geometry.laplacian import adjacency, cotangent_laplacian, vertex_areas
from simcore.geometry.voxelize import VoxelGrid, solid_voxels
from simcore.geometry.weld import weld_vertices
from simcore.mpm.measures import part_volumes, volume_parts
from simcore.skeleton.types import Skeleton
from simcore.skinning.bones import ROWS, closest_on_segments, joint_segments
from simcore.skinning.postprocess import normalize_rows

HEAT_C = 1.0  # Baran & Popović's constant: H_ii = c / d², c = 1
TIE = 1.0001  # bones within 0.01 % of the nearest are heated together (Pinocchio's tie rule)
LINE_SAMPLES = 12  # voxel samples along the vertex-to-bone line
MIN_DISTANCE = 1e-4  # unit-cube floor of the heating distance
LIMIT_START, LIMIT_END = 0.05, 0.025  # weights under START fade linearly to 0 at END (Blender's weight limit)


def _visible(grid: VoxelGrid, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """(N,) bool: the line from each bone point `start` (N, 3) to a surface vertex `end` stays in the solid.

    The last 15 % next to the vertex is not tested: the vertex sits on the surface, where voxels are ragged.
    """
    t = np.linspace(0.0, 0.85, LINE_SAMPLES)
    pts = start[:, None, :] + t[None, :, None] * (end - start)[:, None, :]
    return np.all(grid.inside(pts.reshape(-1, 3)).reshape(len(start), LINE_SAMPLES), axis=1)


def _cone_distances(points: np.ndarray, normals: np.ndarray, heads: np.ndarray, tails: np.ndarray,
                    dist: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(N, S) distances from each point to each segment, stretched by 2 / (cos + 1.001) where cos is the angle
    between the point's normal and the direction from the segment's closest point to it."""
    out = np.empty_like(dist)
    d = tails - heads
    for start in range(0, len(points), ROWS):
        rows = slice(start, start + ROWS)
        closest = heads[None] + t[rows, :, None] * d[None]  # (B, S, 3)
        towards = points[rows, None, :] - closest
        cos = np.einsum("bsc,bc->bs", towards, normals[rows]) / np.maximum(dist[rows], 1e-12)
        out[rows] = dist[rows] / (0.5 * (np.clip(cos, -1.0, 1.0) + 1.001))
    return out


def _outward_normals(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(N, 3) vertex normals, all flipped when the mesh's faces wind inwards: its signed volume, the quality gate's
    (each part's cones from its own centre), is negative. The whole mesh is judged: an open part says nothing."""
    normals = trimesh.Trimesh(points, faces, process=False).vertex_normals
    return -normals if float(part_volumes(points, faces, volume_parts(points, faces)).sum()) < 0 else normals


def _heat_sources(grid: VoxelGrid, points: np.ndarray, label: np.ndarray, heads: np.ndarray, tails: np.ndarray,
                  owner: np.ndarray, joints: int, cone: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(p (N, J) heat share of each joint, h (N,) heat) from the cone distances (N, S) of points to segments."""
    n = len(points)
    nearest = cone.min(axis=1)
    tied = cone <= TIE * nearest[:, None] + 1e-12  # (N, S)
    rows, segs = np.nonzero(tied)
    bone_pts = heads[segs] + t[rows, segs][:, None] * (tails[segs] - heads[segs])
    seen = _visible(grid, bone_pts, points[rows])
    heated = np.zeros(n, bool)
    heated[rows[seen]] = True
    cold = ~np.isin(label, label[heated])  # a part nothing heats: its nearest bones heat it, seen or not
    seen |= cold[rows]
    p = np.zeros((n, joints))
    p[rows[seen], owner[segs[seen]]] = 1.0  # a joint whose two segments tie heats once
    count = p.sum(axis=1)
    h = count * HEAT_C / np.maximum(nearest, MIN_DISTANCE) ** 2
    return normalize_rows(p), h


def _limited(w: np.ndarray) -> np.ndarray:
    """Blender's weight limit: 0 under LIMIT_END, a linear ramp to LIMIT_START, unchanged above."""
    ramp = (w - LIMIT_END) / (LIMIT_START - LIMIT_END) * LIMIT_START
    return np.where(w < LIMIT_END, 0.0, np.where(w < LIMIT_START, ramp, w))


def heat_weights(
    vertices: np.ndarray,
    faces: np.ndarray,
    skeleton: Skeleton,
    *,
    leaf_extension: float = 0.5,  # a leaf bone reaches half its parent bone's length past its joint
    resolution: int = 64,
    progress: Callable[[float], None] = lambda fraction: None,
) -> np.ndarray:
    """(V, J) float64 normalised bone-heat weights for vertices (V, 3) float and faces (F, 3) int.

    Computed on the welded mesh in unit-cube units (longest bounding-box side 1), mapped back so duplicates
    share weights. `progress` is called with the fraction done at each checkpoint (it may raise to stop the
    computation).
    """
    v = np.asarray(vertices, dtype=np.float64)
    lo, hi = v.min(axis=0), v.max(axis=0)
    side = max(float((hi - lo).max()), 1e-12)
    welded = weld_vertices((v - lo) / side, faces)
    wv, wf = welded.vertices, welded.faces
    seg = joint_segments(skeleton, leaf_extension)
    heads, tails = (seg.heads - lo) / side, (seg.tails - lo) / side
    dist, t = closest_on_segments(wv, heads, tails)  # (n, S)
    grid = solid_voxels(wv, wf, resolution=resolution)
    _, label = connected_components(adjacency(wf, len(wv)), directed=False)
    cone = _cone_distances(wv, _outward_normals(wv, wf), heads, tails, dist, t)
    p, h = _heat_sources(grid, wv, label, heads, tails, seg.owner, skeleton.num_joints, cone, t)
    progress(0.35)

    area = vertex_areas(wv, wf)
    area = np.where(area > 0, area, max(float(area[area > 0].mean()) if (area > 0).any() else 1.0, 1e-12))
    # Multiply Baran's −Δ + H by the lumped areas: symmetric, positive definite (every part has a heated vertex).
    system = (-cotangent_laplacian(wv, wf) + sp.diags(area * h)).tocsc()
    # COLAMD ordering: the same solution as MMD on A+Aᵀ, whose ordering step grows much faster with mesh size.
    solve = splu(system, permc_spec="COLAMD")
    progress(0.7)
    w = normalize_rows(_limited(np.clip(solve.solve((area * h)[:, None] * p), 0.0, 1.0)))
    empty = w.sum(axis=1) == 0
    w[empty] = np.eye(skeleton.num_joints)[seg.owner[np.argmin(cone[empty], axis=1)]]
    progress(1.0)
    return w[welded.index]
