"""Solid voxelisation robust to holes, several components and self-intersections.

Surface voxels are rasterised from dense barycentric samples, made in bounded chunks and within the job's
surface-sample budget (simcore.budgets); the shell is dilated by `close_radius` voxels so that holes up to
about that size seal, everything not reachable from the grid border is inside, and the dilation is undone by
an erosion (surface voxels are always kept). Used by skeleton extraction, geodesic skinning and MPM sampling.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from simcore import budgets
from simcore.arrays import unique_ints
from simcore.errors import LimitExceeded

PAD = 2  # empty voxels around the mesh so the outside is one connected region
MAX_STEPS = 256  # lattice steps along a triangle's longest edge, at most
JOINT_TEST_RESOLUTION = 128  # voxels along the longest side of the solid every joints-inside test uses
# (quality gate, skeleton metrics, candidate score) and that rigs from motion move their joints into
CHUNK_POINTS = 1 << 20  # lattice points made at once: bounds the voxeliser's working memory


@dataclass
class VoxelGrid:
    """Occupancy on a regular grid.

    origin:    (3,) float64 world position of the centre of voxel (0, 0, 0), metres.
    pitch:     voxel edge length, metres.
    occupancy: (X, Y, Z) bool, True = inside the solid or on its surface.
    surface:   (X, Y, Z) bool, True = a triangle passes through the voxel.
    """

    origin: np.ndarray
    pitch: float
    occupancy: np.ndarray
    surface: np.ndarray

    def centers(self, ijk: np.ndarray) -> np.ndarray:
        """(N, 3) world centres of integer voxel indices (N, 3)."""
        return self.origin + np.asarray(ijk, dtype=np.float64) * self.pitch

    def index_of(self, points: np.ndarray) -> np.ndarray:
        """(N, 3) int64 voxel index containing each point (may be out of range)."""
        return np.floor((np.asarray(points, dtype=np.float64) - self.origin) / self.pitch + 0.5).astype(np.int64)

    def in_bounds(self, ijk: np.ndarray) -> np.ndarray:
        """(N,) bool: index lies inside the grid."""
        return np.all((ijk >= 0) & (ijk < np.asarray(self.occupancy.shape)), axis=1)

    def inside(self, points: np.ndarray) -> np.ndarray:
        """(N,) bool: point falls in an occupied voxel."""
        ijk = self.index_of(points)
        ok = self.in_bounds(ijk)
        out = np.zeros(len(ijk), bool)
        out[ok] = self.occupancy[tuple(ijk[ok].T)]
        return out


def _barycentric(n: int) -> np.ndarray:
    """(K, 3) barycentric coordinates of the points of an n-step lattice on a triangle, corners included."""
    a, b = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    keep = a + b <= n
    return np.stack([a[keep], b[keep], n - a[keep] - b[keep]], axis=1) / n


def _lattice_steps(tri: np.ndarray, spacing: float) -> np.ndarray:
    """(F,) int64 lattice steps per triangle of tri (F, 3, 3): its longest edge over `spacing`, 1..MAX_STEPS."""
    edge = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1)
    return np.clip(np.ceil(edge / spacing), 1, MAX_STEPS).astype(np.int64)


def _check_sample_budget(steps: np.ndarray) -> None:
    """Refuse a mesh whose triangles need more lattice points than the job's surface-sample budget."""
    limit = budgets.current().surface_samples
    needed = int(((steps + 1) * (steps + 2) // 2).sum())
    if needed > limit:
        raise LimitExceeded(
            f"the mesh's triangles need {needed:,} surface samples to voxelise, more than the limit of {limit:,} "
            "(RIGFORGE_BUDGETS__SURFACE_SAMPLES): it has many huge or overlapping triangles; remesh it into smaller ones",
            code="too_large", field="mesh")


def _lattice_points(tri: np.ndarray, spacing: float, min_steps: int = 1) -> Iterator[np.ndarray]:
    """Lattice points of triangles tri (F, 3, 3), no two neighbours farther apart than `spacing`: (N, 3) arrays of
    at most about CHUNK_POINTS points (a triangle whose longest edge needs n steps gets an n-step lattice).
    Raises LimitExceeded (too_large) before making any when they would be more than the surface-sample budget."""
    steps = _lattice_steps(tri, spacing)
    _check_sample_budget(steps[steps >= min_steps])
    for n in np.unique(steps[steps >= min_steps]):
        lattice = _barycentric(int(n))
        chosen = np.flatnonzero(steps == n)
        per_chunk = max(1, CHUNK_POINTS // len(lattice))
        for start in range(0, len(chosen), per_chunk):
            yield np.matmul(lattice[None], tri[chosen[start:start + per_chunk]]).reshape(-1, 3)  # 6× faster than einsum


def surface_samples(vertices: np.ndarray, faces: np.ndarray, spacing: float) -> np.ndarray:
    """(N, 3) deterministic points on every triangle, no two neighbours farther apart than `spacing`."""
    tri = np.asarray(vertices, dtype=np.float64)[np.asarray(faces, dtype=np.int64)]
    return np.concatenate([tri.reshape(-1, 3), *_lattice_points(tri, spacing)])


def solid_voxels(vertices: np.ndarray, faces: np.ndarray, resolution: int = 64, close_radius: int = 1) -> VoxelGrid:
    """Voxelise the solid bounded by a triangle soup.

    vertices: (V, 3) float, faces: (F, 3) int. `resolution` voxels span the longest bounding-box side.
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    lo, hi = v.min(axis=0), v.max(axis=0)
    pitch = max(float((hi - lo).max()) / max(resolution - 1, 1), 1e-9)
    pad = PAD + close_radius
    origin = lo - pad * pitch
    shape = np.ceil((hi - lo) / pitch).astype(np.int64) + 1 + 2 * pad
    grid = VoxelGrid(origin, pitch, np.zeros(shape, bool), np.zeros(shape, bool))
    # Mark the voxels of the face corners and of the lattice points of faces longer than half a voxel (a 1-step
    # lattice is the corners again), by flat index; the padding keeps every point inside the grid.
    strides = np.array([shape[1] * shape[2], shape[2], 1])
    surface = grid.surface.reshape(-1)  # a view
    for points in itertools.chain([v[unique_ints(f)]], _lattice_points(v[f], pitch * 0.5, min_steps=2)):
        surface[grid.index_of(points) @ strides] = True
    shell = ndimage.binary_dilation(grid.surface, iterations=close_radius) if close_radius else grid.surface
    labels, _ = ndimage.label(~shell)
    border = unique_ints(np.concatenate([labels[[0, -1]].ravel(), labels[:, [0, -1]].ravel(), labels[:, :, [0, -1]].ravel()]))
    inside = ~np.isin(labels, border[border > 0])
    if close_radius:
        inside = ndimage.binary_erosion(inside, iterations=close_radius, border_value=0)
    grid.occupancy = inside | grid.surface
    return grid
