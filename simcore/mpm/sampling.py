"""Volumetric particle sampling of a mesh (PhysRig A.2), with a particle budget.

Voxels of the solid (robust to holes: `solid_voxels`) each get random points, kept when a voxelisation at
twice the resolution finds them strictly inside (not in its surface shell); surface samples and every original vertex are added, so every
output vertex is a particle. Over budget, interior and surface samples are thinned first; only when the
vertices alone exceed half the budget are vertices thinned too (those then follow their nearest simulated
vertices, see `vertex_particles`). Particles are ordered by voxel so neighbours sit together in memory.
`sample_on_grid` samples for a simulation grid (rounded up to whole blocks of the kernels' sparse grid) and coarsens
that grid when the budget would leave too few particles in each of its cells to hold the solid together.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from simcore.geometry.referenced import referenced_mesh
from simcore.geometry.voxelize import solid_voxels, surface_samples
from simcore.mpm.kernels import BLOCK

# Fewest particles per grid cell of the solid that a simulation keeps: MPM's usual fill is 8 (two per axis);
# below about half that, cells between particles get no mass and the continuum tears into clumps.
MIN_PARTICLES_PER_CELL = 4.0
SMALLEST_GRID = 16  # options.refine.grid's lower bound


@dataclass
class ParticleSample:
    """positions: (N, 3) float64 rest positions, metres.
    vertex_particles: (V,) int64 particle index of each mesh vertex, -1 for vertices thinned by the budget
                      and for vertices no face uses.
    volume: solid volume, m³; particle_volume: volume / N, m³.
    counts: particles by origin after the budget ("interior", "surface", "vertices"); notes: what was thinned.
    """

    positions: np.ndarray
    vertex_particles: np.ndarray
    volume: float
    particle_volume: float
    counts: dict[str, int] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    @property
    def count(self) -> int:
        return int(len(self.positions))


def _thin(rng: np.random.Generator, n: int, keep: int) -> np.ndarray:
    return np.sort(rng.choice(n, size=keep, replace=False)) if keep < n else np.arange(n)


def sample_volume(vertices: np.ndarray, faces: np.ndarray, spacing: float, *, per_voxel: int = 8,
                  max_particles: int | None = None, seed: int = 0) -> ParticleSample:
    """Fill the mesh with particles about `spacing` metres apart.

    vertices: (V, 3) float, faces: (F, 3) int. Voxels have edge 2·spacing with `per_voxel` random points each
    (8: about two per axis). Deterministic for a given seed.
    """
    mesh = referenced_mesh(vertices, faces)  # vertices no face uses get no particle and set no size
    v, faces = mesh.vertices, mesh.faces
    rng = np.random.default_rng(seed)
    pitch = 2.0 * float(spacing)
    extent = float((v.max(axis=0) - v.min(axis=0)).max())
    resolution = int(np.clip(np.ceil(extent / pitch) + 1, 4, 256))
    coarse = solid_voxels(v, faces, resolution=resolution)
    fine = solid_voxels(v, faces, resolution=2 * resolution - 1)
    ijk = np.argwhere(coarse.occupancy)
    jitter = rng.uniform(-0.5, 0.5, (len(ijk), per_voxel, 3)) * coarse.pitch
    interior = (coarse.centers(ijk)[:, None, :] + jitter).reshape(-1, 3)
    fine_ijk = fine.index_of(interior)
    in_shell = np.zeros(len(interior), bool)
    ok = fine.in_bounds(fine_ijk)
    in_shell[ok] = fine.surface[tuple(fine_ijk[ok].T)]
    interior = interior[fine.inside(interior) & ~in_shell]  # the surface layer is covered by surface samples
    volume = float(fine.occupancy.sum() - 0.5 * fine.surface.sum()) * fine.pitch**3
    surface = surface_samples(v, faces, spacing)
    area = float(np.linalg.norm(np.cross(v[faces[:, 1]] - v[faces[:, 0]], v[faces[:, 2]] - v[faces[:, 0]]), axis=1).sum() / 2)
    surface = surface[_thin(rng, len(surface), int(np.ceil(area / spacing**2)))]

    notes: list[str] = []
    vkeep = np.arange(len(v))  # into the referenced vertices
    if max_particles is not None:
        if len(v) > max_particles // 2:
            vkeep = _thin(rng, len(v), max_particles // 2)
            notes.append(f"{len(v) - len(vkeep)} of {len(v)} vertices not simulated (budget {max_particles}); "
                         "they follow their nearest simulated vertices")
        room = max_particles - len(vkeep)
        total = len(interior) + len(surface)
        if total > room:
            keep_i = int(round(room * len(interior) / max(total, 1)))
            notes.append(f"volume samples thinned from {total} to {room} (budget {max_particles})")
            interior = interior[_thin(rng, len(interior), keep_i)]
            surface = surface[_thin(rng, len(surface), room - keep_i)]
    points = np.concatenate([interior, surface, v[vkeep]])
    origin_of = np.repeat(np.arange(3), [len(interior), len(surface), len(vkeep)])
    cell = coarse.index_of(points)
    order = np.lexsort((cell[:, 2], cell[:, 1], cell[:, 0]))  # voxel-major order: cache-friendly scatter
    points, origin_of = points[order], origin_of[order]
    rank = np.empty(len(order), np.int64)
    rank[order] = np.arange(len(order))
    vertex_particles = np.full(mesh.count, -1, np.int64)
    vertex_particles[mesh.ids[vkeep]] = rank[len(interior) + len(surface):]
    counts = {"interior": int(np.sum(origin_of == 0)), "surface": int(np.sum(origin_of == 1)), "vertices": int(len(vkeep))}
    return ParticleSample(points, vertex_particles, volume, volume / max(len(points), 1), counts, notes)


def nearest_rows(sources: np.ndarray, values: sp.spmatrix | np.ndarray, targets: np.ndarray, k: int = 4) -> sp.csr_matrix:
    """(M, C) rows for targets (M, 3): inverse-distance blend of `values` (S, C) at the k nearest sources (S, 3)."""
    k = min(k, len(sources))
    dist, idx = cKDTree(sources).query(targets, k=k)
    dist, idx = dist.reshape(len(targets), k), idx.reshape(len(targets), k)
    w = 1.0 / np.maximum(dist, 1e-9)
    w /= w.sum(axis=1, keepdims=True)
    blend = sp.csr_matrix((w.ravel(), (np.repeat(np.arange(len(targets)), k), idx.ravel())), shape=(len(targets), len(sources)))
    return sp.csr_matrix(blend @ values)


@dataclass(frozen=True)
class GridSample:
    """A particle sample for a simulation grid: the sample, the grid (nodes per axis, a multiple of BLOCK) and its
    spacing dx (metres), particles per cell of the solid, and a note when the grid differs from the one asked for."""

    sample: ParticleSample
    grid: int
    dx: float
    per_cell: float
    note: str | None = None


def _per_cell(sample: ParticleSample, dx: float) -> float:
    return sample.count * dx**3 / max(sample.volume, 1e-30)


def sample_on_grid(vertices: np.ndarray, faces: np.ndarray, extent: float, grid: int, pad: int, *,
                   max_particles: int | None, seed: int = 0) -> GridSample:
    """Particles half a cell apart for a `grid`-node domain whose `grid - pad` inner cells span `extent` metres.

    `grid` is first rounded up to a multiple of BLOCK (the kernels' sparse grid is made of BLOCK³ node blocks).
    Under a budget the particle count is fixed, so particles per cell fall with the cube of the cell size: when
    they would be under MIN_PARTICLES_PER_CELL, the grid is coarsened (to a multiple of BLOCK, at least
    SMALLEST_GRID) until they are not, and sampled again at the coarser spacing. The note says what changed.
    """
    asked, grid = grid, BLOCK * -(-grid // BLOCK)
    rounded = f"grid rounded up from {asked} to {grid} (multiple of the {BLOCK}³ block)" if grid != asked else None
    dx = extent / (grid - pad)
    sample = sample_volume(vertices, faces, 0.5 * dx, max_particles=max_particles, seed=seed)
    per_cell = _per_cell(sample, dx)
    if per_cell >= MIN_PARTICLES_PER_CELL:
        return GridSample(sample, grid, dx, per_cell, rounded)
    wanted = dx * (MIN_PARTICLES_PER_CELL / per_cell) ** (1.0 / 3.0)
    coarse = max(BLOCK * int((extent / wanted + pad) // BLOCK), SMALLEST_GRID)
    if coarse >= grid:
        return GridSample(sample, grid, dx, per_cell, rounded)
    coarse_dx = extent / (coarse - pad)
    coarse_sample = sample_volume(vertices, faces, 0.5 * coarse_dx, max_particles=max_particles, seed=seed)
    coarse_per_cell = _per_cell(coarse_sample, coarse_dx)
    note = (f"grid lowered from {grid} to {coarse}: {sample.count} particles (the budget) fill a cell of the solid "
            f"{per_cell:.1f} times at {grid}, {coarse_per_cell:.1f} at {coarse} (at least {MIN_PARTICLES_PER_CELL:g} "
            "hold it together); raise the particle budget to keep the finer grid")
    return GridSample(coarse_sample, coarse, coarse_dx, coarse_per_cell, "; ".join(filter(None, [rounded, note])))
