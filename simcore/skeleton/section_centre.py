"""Sub-voxel joint placement: each chain joint moves towards the centre of its limb's cross-section.

Medial joints are voxel centres, so a bone can sit up to half a voxel off its limb's axis. The cross-section
through a joint, across its bone, is read from the solid smoothed to a sub-voxel surface (the 0.5 level of the
occupancy blurred by SECTION_SIGMA voxels) along SECTION_RAYS evenly spread rays, and its centre is the point that
best fits the middles of the chords they make with their opposite rays. The move is capped at SECTION_LIMIT
voxels, about half a voxel face's diagonal (0.71): the joint is refined within its voxel, never carried to another
part of a junction or a bend.
Centring brings bones onto their limb's axis and keeps joints inside thin parts of the mesh; a rig whose artist
ran a bone off-centre on purpose (a spine along the back) can end up a little further from it.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from simcore.geometry.voxelize import VoxelGrid

SECTION_RAYS = 16
SECTION_SIGMA = 0.7  # voxels of Gaussian blur that turn the occupancy into a smooth surface
SECTION_STEP = 0.25  # voxels between samples along a ray
SECTION_REACH = 40.0  # voxels: a ray that stays inside this far finds no surface (an open or a huge section)
SECTION_LIMIT = 0.75  # voxels a joint may move


def _across(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (J, 3) each, orthogonal to each other and to the unit directions `d` (J, 3)."""
    helper = np.where(np.abs(d[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    u = np.cross(d, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    return u, np.cross(d, u)


def centre_in_section(positions: np.ndarray, parents: np.ndarray, grid: VoxelGrid,
                      limit: float = SECTION_LIMIT) -> np.ndarray:
    """(J, 3) copy of `positions` with every non-root joint that has at most one child moved towards the centre
    of the cross-section through it, across its bone (parent → child, or parent → itself at a leaf), by at most
    `limit` voxels. Junctions (two or more children) have no single cross-section and stay; so does a joint whose
    section has a ray that finds no surface.
    parents: (J,) int64, root -1, parents before children.
    """
    pos = np.asarray(positions, dtype=np.float64)
    out = pos.copy()
    children = np.bincount(parents[parents >= 0], minlength=len(pos))
    child = np.full(len(pos), -1)
    child[parents[parents >= 0]] = np.flatnonzero(parents >= 0)  # one child each, where there is exactly one
    picked = np.flatnonzero((parents >= 0) & (children <= 1))
    ahead = np.where(children[picked] == 1, child[picked], picked)
    bone = pos[ahead] - pos[parents[picked]]
    length = np.linalg.norm(bone, axis=1)
    picked, bone, length = picked[length > 0], bone[length > 0], length[length > 0]
    if len(picked) == 0:
        return out
    u, w = _across(bone / length[:, None])
    angle = 2 * np.pi * np.arange(SECTION_RAYS) / SECTION_RAYS
    rays = np.cos(angle)[None, :, None] * u[:, None] + np.sin(angle)[None, :, None] * w[:, None]  # (P, R, 3)
    steps = np.arange(0.0, SECTION_REACH, SECTION_STEP)
    start = (pos[picked] - grid.origin) / grid.pitch  # voxel coordinates
    samples = start[:, None, None] + steps[None, None, :, None] * rays[:, :, None]  # (P, R, S, 3)
    solid = ndimage.gaussian_filter(grid.occupancy.astype(np.float32), SECTION_SIGMA)
    level = ndimage.map_coordinates(solid, samples.reshape(-1, 3).T, order=1, mode="constant", cval=0.0)
    level = level.reshape(samples.shape[:3])
    outside = level < 0.5
    exits = outside.any(axis=2).all(axis=1) & ~outside[:, :, 0].any(axis=1)
    first = np.argmax(outside, axis=2)  # (P, R) first sample outside
    prev = np.maximum(first - 1, 0)
    a = np.take_along_axis(level, prev[..., None], axis=2)[..., 0]
    b = np.take_along_axis(level, first[..., None], axis=2)[..., 0]
    hit = steps[prev] + (a - 0.5) / np.maximum(a - b, 1e-9) * SECTION_STEP  # where the level crosses 0.5
    # The chord along ray k and its opposite has its middle at (hit_k - hit_opposite) / 2 along ray k; the point
    # that best fits all those middles is, with evenly spread rays, twice the mean of the exit vectors.
    offset = 2.0 * (hit[..., None] * rays).mean(axis=1)  # voxels, in the section's plane
    size = np.linalg.norm(offset, axis=1, keepdims=True)
    offset *= np.minimum(1.0, limit / np.maximum(size, 1e-12))
    out[picked[exits]] += offset[exits] * grid.pitch
    return out
