"""Bone heat weights (Baran & Popović 2007, "Pinocchio"; Blender's automatic weights).

Each joint's weight is the equilibrium temperature of the surface when that joint's bones are heated:
(−L + H) w_j = H p_j, with L the cotangent Laplacian (welded mesh, area-weighted), H_ii = c / d_i² where d_i
is the distance from vertex i to the nearest bone it can *see* (the straight line to it stays inside the
solid voxelisation), and p_ij = 1 when joint j owns that bone. One sparse LU factorisation serves all joints.
Duplicate (seam, flat-shaded) vertices are welded first; otherwise every triangle is its own island and the
diffusion does nothing, which is why Blender needs "merge by distance" on such meshes.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from simcore.geometry.laplacian import cotangent_laplacian, vertex_areas
from simcore.geometry.voxelize import VoxelGrid, solid_voxels
from simcore.geometry.weld import weld_vertices
from simcore.skeleton.types import Skeleton
from simcore.skinning.bones import closest_on_segments, joint_segments
from simcore.skinning.postprocess import normalize_rows

HEAT_C = 1.0  # Baran & Popović's constant: H_ii = c / d², c = 1
TIE = 1.0001  # bones within 0.01 % of the nearest are heated together (Pinocchio's tie rule)
CANDIDATES = 6  # nearest segments tested for visibility per vertex; none visible → the nearest one
LINE_SAMPLES = 12  # voxel samples along the vertex-to-bone line


def _visible(grid: VoxelGrid, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """(N,) bool: the line from each bone point `start` (N, 3) to a surface vertex `end` stays in the solid.

    The last 15 % next to the vertex is not tested: the vertex sits on the surface, where voxels are ragged.
    """
    t = np.linspace(0.0, 0.85, LINE_SAMPLES)
    pts = start[:, None, :] + t[None, :, None] * (end - start)[:, None, :]
    return np.all(grid.inside(pts.reshape(-1, 3)).reshape(len(start), LINE_SAMPLES), axis=1)


def heat_weights(
    vertices: np.ndarray,
    faces: np.ndarray,
    skeleton: Skeleton,
    *,
    leaf_extension: float = 0.5,  # a leaf bone reaches half its parent bone's length past its joint
    resolution: int = 64,
    heat_c: float = HEAT_C,
    min_weight: float = 1e-3,
    progress: Callable[[float], None] = lambda fraction: None,
) -> np.ndarray:
    """(V, J) float64 normalised bone-heat weights for vertices (V, 3) float and faces (F, 3) int.

    Computed on the welded mesh in unit-cube units (longest bounding-box side 1), mapped back so duplicates
    share weights. Weights below `min_weight` are dropped before renormalising (as Blender does). `progress` is
    called with the fraction done at each checkpoint (it may raise to stop the computation).
    """
    v = np.asarray(vertices, dtype=np.float64)
    lo, hi = v.min(axis=0), v.max(axis=0)
    side = max(float((hi - lo).max()), 1e-12)
    welded = weld_vertices((v - lo) / side, faces)
    wv, wf = welded.vertices, welded.faces
    n, j = len(wv), skeleton.num_joints
    seg = joint_segments(skeleton, leaf_extension)
    heads, tails = (seg.heads - lo) / side, (seg.tails - lo) / side
    dist, t = closest_on_segments(wv, heads, tails)  # (n, S)
    grid = solid_voxels(wv, wf, resolution=resolution)

    # Nearest visible segment per vertex among the CANDIDATES nearest.
    m = min(CANDIDATES, dist.shape[1])
    cand = np.argsort(dist, axis=1)[:, :m]  # (n, m)
    sorted_d = np.take_along_axis(dist, cand, axis=1)
    vis = np.zeros((n, m), bool)
    seen = np.full(n, np.inf)  # distance of the nearest visible candidate found so far
    for k in range(m):  # nearest first; a farther candidate is tested only while it could still be (tied) nearest
        rows = np.flatnonzero(sorted_d[:, k] <= TIE * seen + 1e-12)
        cs = cand[rows, k]
        bone_pts = heads[cs] + t[rows, cs][:, None] * (tails[cs] - heads[cs])
        vis[rows, k] = _visible(grid, bone_pts, wv[rows])
        hit = rows[vis[rows, k]]
        seen[hit] = np.minimum(seen[hit], sorted_d[hit, k])
    vis[~vis.any(axis=1), 0] = True  # nothing visible: the nearest bone (Pinocchio's fallback)
    cand_d = np.where(vis, sorted_d, np.inf)
    nearest = cand_d.min(axis=1)
    heated = cand_d <= TIE * nearest[:, None] + 1e-12  # (n, m)

    p = np.zeros((n, j))
    owners = seg.owner[cand]
    for k in range(m):
        np.add.at(p, (np.flatnonzero(heated[:, k]), owners[heated[:, k], k]), 1.0)
    p = normalize_rows(np.minimum(p, 1.0))
    h = heat_c / np.maximum(nearest, 1e-4) ** 2
    progress(0.35)

    area = vertex_areas(wv, wf)
    area = np.where(area > 0, area, max(float(area[area > 0].mean()) if (area > 0).any() else 1.0, 1e-12))
    # Multiply Baran's −Δ + H by the lumped areas: symmetric, positive definite (H > 0 everywhere).
    system = (-cotangent_laplacian(wv, wf) + sp.diags(area * h)).tocsc()
    # COLAMD ordering: the same solution as MMD on A+Aᵀ, whose ordering step grows much faster with mesh size.
    solve = splu(system, permc_spec="COLAMD")
    progress(0.7)
    w = solve.solve((area * h)[:, None] * p)
    w = np.clip(w, 0.0, 1.0)
    w[w < min_weight] = 0.0
    w = normalize_rows(w)
    empty = w.sum(axis=1) == 0
    w[empty] = p[empty]
    progress(1.0)
    return w[welded.index]
